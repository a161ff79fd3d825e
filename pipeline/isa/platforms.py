"""Platforms: named sets of architectures that one shader ships to (a desktop build runs it on AMD,
NVIDIA and Intel GPUs, an Android build on Adreno and Mali GPUs), with the format its shaders
compute in. The data is `platforms.toml` beside this module; a user's file adds platforms or
replaces one of the same name (`read`). `architectures_of` turns `--gpu` words, each a platform's or
an architecture's name, into architectures."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ..engine.toml_files import read_toml
from .architectures import ARCHITECTURES

DEFAULT = Path(__file__).with_name("platforms.toml")
KEYS = ("architectures", "precision", "description")
PRECISIONS = ("fp32", "fp16")


class PlatformError(ValueError):
    """A platforms file or a `--gpu` word that is wrong, in one line naming it."""


@dataclasses.dataclass(frozen=True)
class Platform:
    """`name`, its `architectures` (the registry's names, in its order), the `precision` its
    shaders compute in, and a `description`."""

    name: str
    architectures: tuple[str, ...]
    precision: str
    description: str = ""


def _platform(name: str, table, where: str) -> Platform:
    if not isinstance(table, dict):
        raise PlatformError(f"{where}: {name} = {table!r}: a platform is a table ([{name}])")
    if name in ARCHITECTURES:
        raise PlatformError(f"{where}: [{name}]: an architecture's name; name the platform otherwise")
    unknown = [k for k in table if k not in KEYS]
    if unknown:
        raise PlatformError(f"{where}: [{name}] {unknown[0]}: unknown key; the keys are {', '.join(KEYS)}")
    names = table.get("architectures")
    if names == "all":
        names = list(ARCHITECTURES)
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise PlatformError(f"{where}: [{name}] architectures: give a list of architectures' names, or \"all\"")
    wrong = [n for n in names if n not in ARCHITECTURES]
    if wrong:
        raise PlatformError(f"{where}: [{name}] architectures: {wrong[0]!r} is not an architecture; they are "
                            f"{', '.join(ARCHITECTURES)}")
    precision = table.get("precision", "fp32")
    if precision not in PRECISIONS:
        raise PlatformError(f"{where}: [{name}] precision = {precision!r}: give one of {', '.join(PRECISIONS)}")
    description = table.get("description", "")
    if not isinstance(description, str):
        raise PlatformError(f"{where}: [{name}] description: give a string")
    return Platform(name, tuple(a for a in ARCHITECTURES if a in names), precision, description)


def read(path=None) -> dict[str, Platform]:
    """{name: Platform} of `platforms.toml`, then of the user's file `path` where given (its tables
    added, or replacing one of the same name). Raises PlatformError naming the file and the fault."""
    out = {}
    for source in [DEFAULT] + ([Path(path)] if path is not None else []):
        tables = read_toml(source, "the platforms file", PlatformError)
        out |= {name: _platform(name, table, str(source)) for name, table in tables.items()}
    return out


def architectures_of(words, platforms: dict[str, Platform]) -> list[str]:
    """The architectures `words` name (each a platform's name, for its architectures, or an
    architecture's), in the order named, each once. Raises PlatformError naming an unknown word."""
    out = []
    for word in words:
        if word in platforms:
            out += platforms[word].architectures
        elif word in ARCHITECTURES:
            out.append(word)
        else:
            raise PlatformError(f"--gpu {word!r}: neither a platform ({', '.join(platforms)}) nor an architecture "
                                f"({', '.join(ARCHITECTURES)})")
    return list(dict.fromkeys(out))
