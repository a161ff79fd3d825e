import subprocess
import sys

import pytest

from pipeline.engine import paths
from pipeline.engine.config import ConfigError, load_config, parse_override

from ..helpers import cli_env

BAD = [
    ("derivation.Q=1.5", r"'derivation.Q' = 1.5 is not allowed: expected a number in \(0, 1\), \"scan\" or \"optimize\""),
    ("derivation.Q=0", r"'derivation.Q' = 0 is not allowed"),
    ("derivation.n_min=0", r"'derivation.n_min' = 0 is not allowed: expected an integer >= 1"),
    ("derivation.n_max=2", r"'derivation.n_max' = 2 is not allowed: expected an integer > derivation.n_min = 2"),
    ("derivation.n_min=2.5", r"'derivation.n_min' = 2.5 is not allowed: expected an integer >= 1"),
    ("derivation.n_max=true", r"'derivation.n_max' = True is not allowed"),
    ("solver.rtol=-1e-9", r"'solver.rtol' = -1e-09 is not allowed: expected a number in \(0, 1e-3\]"),
    ("derivation.metric=max", r"'derivation.metric' = 'max' is not allowed"),
    ("derivation.speed=3", r"config key 'derivation.speed' is unknown: allowed keys in \[derivation\] are n_min"),
    ("derivation.Q=0.5", r"'derivation.constants' = 'paper' is not allowed: expected \"fitted\""),
    ("regression.library=[\"n\"]", r"'regression.library' = \['n'\] is not allowed"),
]


@pytest.mark.parametrize("override,message", BAD)
def test_bad_values_name_the_key_the_value_and_what_is_allowed(override, message):
    with pytest.raises(ConfigError, match=message):
        load_config(paths.PAPER_CONFIG, (override,))


def test_set_without_equals_sign():
    with pytest.raises(ConfigError, match=r"--set 'derivation.Q' is not allowed: expected KEY=VALUE"):
        parse_override("derivation.Q")


def test_set_values_are_toml_literals_or_bare_strings():
    assert parse_override("derivation.Q=0.5") == ("derivation.Q", 0.5)
    assert parse_override("derivation.Q=optimize") == ("derivation.Q", "optimize")
    assert parse_override('derivation.constants="fitted"') == ("derivation.constants", "fitted")
    assert parse_override("zone.sensitivity_levels=[0.5, 0.6]") == ("zone.sensitivity_levels", [0.5, 0.6])


def test_negative_tolerance_in_an_expectation(tmp_path):
    text = paths.PAPER_CONFIG.read_text().replace("tolerance = 5e-4\nreason = \"printed to 3 decimals\"\n",
                                                  "tolerance = -5e-4\nreason = \"printed to 3 decimals\"\n", 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(ConfigError, match=r"'expectations.P5_slope.tolerance' = -0.0005 is not allowed: expected a number >= 0"):
        load_config(bad)


def test_unknown_section_and_broken_toml(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[derivaton]\nQ = 0.5\n")
    with pytest.raises(ConfigError, match=r"config section '\[derivaton\]' is unknown"):
        load_config(bad)
    bad.write_text("[derivation\n")
    with pytest.raises(ConfigError, match="is not valid TOML"):
        load_config(bad)


def run_cli(args, tmp_path):
    return subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True, text=True,
                          env=cli_env(tmp_path), cwd=paths.ROOT)


@pytest.mark.parametrize("args,message", [
    (["refit", "--config", "configs/paper.toml", "--set", "derivation.Q=1.5", "--out", "x"], "'derivation.Q' = 1.5"),
    (["refit", "--config", "configs/paper.toml", "--set", "derivation.Q", "--out", "x"], "expected KEY=VALUE"),
    (["refit", "--config", "configs/paper.toml"], "'run.name' = 'paper' is not allowed for a refit"),
    (["refit", "--config", "configs/missing.toml"], "config file 'configs/missing.toml' does not exist"),
])
def test_cli_bad_input_exits_2_and_writes_nothing(args, message, tmp_path):
    proc = run_cli(args, tmp_path)
    assert proc.returncode == 2
    assert message in proc.stderr
    assert proc.stderr.count("\n") == 1          # one message
    assert not (tmp_path / "cache").exists() and not (tmp_path / "out").exists()


def test_the_readme_lists_every_config_key_as_pipeline_keys_does():
    from pipeline.engine import paths
    from pipeline.engine.config import key_table
    readme = (paths.ROOT / "README.md").read_text()
    assert key_table().strip() in readme
