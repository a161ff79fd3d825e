"""The one reader of the TOML files a user gives (a config, a sweep, a derive target, a cost table),
each fault in one line of one style naming the file: it does not exist, is a directory, is not
UTF-8 text, cannot be read, or is not valid TOML."""

from __future__ import annotations

import tomllib
from pathlib import Path


def read_toml(path, what: str, error: type[Exception] = ValueError) -> dict:
    """The TOML file `path`'s tables. Raises `error` with "<what> '<path>' ..." naming the fault."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise error(f"{what} '{path}' does not exist") from None
    except IsADirectoryError:
        raise error(f"{what} '{path}' is a directory, not a TOML file") from None
    except UnicodeDecodeError as e:
        raise error(f"{what} '{path}' is not UTF-8 text (byte {e.start}): not a TOML file") from None
    except OSError as e:
        raise error(f"{what} '{path}' cannot be read: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise error(f"{what} '{path}' is not valid TOML: {e}") from None
