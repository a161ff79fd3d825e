"""The one reader of a user's TOML files: each fault one line naming the file, in the caller's error."""

import pytest

from pipeline.engine.config import ConfigError
from pipeline.engine.toml_files import read_toml


def test_each_fault_is_one_line_naming_the_file(tmp_path):
    (tmp_path / "good.toml").write_text('[a]\nb = 1\n')
    assert read_toml(tmp_path / "good.toml", "config file") == {"a": {"b": 1}}
    (tmp_path / "bad.toml").write_text("[a\n")
    (tmp_path / "latin.toml").write_bytes(b"a = '\xe9'\n")
    for path, message in ((tmp_path / "missing.toml", "does not exist"),
                          (tmp_path, "is a directory, not a TOML file"),
                          (tmp_path / "latin.toml", r"is not UTF-8 text \(byte 5\): not a TOML file"),
                          (tmp_path / "bad.toml", "is not valid TOML: ")):
        with pytest.raises(ConfigError, match=f"^sweep file '{path}' {message}") as raised:
            read_toml(path, "sweep file", ConfigError)
        assert "\n" not in str(raised.value)
