"""How long an exhaustive search takes on this machine: the rates behind the time `pipeline regress`
and `pipeline derive` print before a search starts, and behind how deep a time budget reaches.

A search's time is its compilation plus its fits (`search.search`; the units of work are `search.screen_units` and `search.refit_units`):
- compilation: `compile_s` seconds for the XLA programs of a search whose programs are not compiled
  yet in this process (none once they are: a later search of the same process, or the kept programs
  of `use_compilation_cache`, skip most of it);
- the screening: `screen_s` seconds per screened form-point (every form, from its starts, on the
  screened points: all of them, or the `search.SCREEN_POINTS` subsample, padded to
  `search.padded_points`, plus every form evaluated once on every point where subsampled);
- the refits: `refit_s` seconds per refitted row-point (`refit_units`: the best forms of each
  complexity from several starts, and for the max losses their minimax refit);
- the float64 polish of pyoperon's models (`operon.polished`): `polish_s` seconds per polished
  row-point (`search.polish_units`: every model from several starts on every point, to convergence);
- pyoperon's evolution (`operon.seeded_models`): `operon_s` seconds per generation-point
  (`operon.generation_units`: a generation of its population on the points, two threads).

The rates serve two ends. The default rates (`DEFAULTS`, the reference machine's) turn a budget in
seconds into the ladder's plan of work before a search starts (`ladder.plan`): a plan, and so a
front, never depends on this machine's speed or load. The kept rates of this machine forecast how
long a plan takes here (`ladder.forecast`), the time printed before a search and reported beside the
time it took.

The rates are kept per kind of search: the opcodes (`arithmetic`: + - * / only; `functions`: any
other) and the loss (`squares`: rms and relative; `max`: max and max-relative). Each search of
`pipeline regress` and `pipeline derive` times its phases (compilation by JAX's monitoring events,
apart from the fits) and moves the kept rates halfway to what it measured (`record`), so that the
estimate follows the machine and its load; the defaults were measured on the 2-core machine the
project is developed on. The rates live in `rates_file()` (`.cache/rates.json`, or
`PIPELINE_RATES`); an unreadable file is replaced by the defaults.
"""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path

KINDS = ("arithmetic/squares", "arithmetic/max", "functions/squares", "functions/max")
# Measured on the project's 2-core machine (one process, XLA on both cores), December 2026; the max
# losses refit by minimax too. pyoperon's operon_s: 40 generations of a population of 1000 on 60,
# 400 and 3000 points of one and two variables took 0.04 to 0.07, 0.09 to 0.11 and 0.52 to 0.57 s a
# generation (1.6e-4 s per generation-point, `operon.generation_units`).
DEFAULTS = {
    "arithmetic/squares": dict(screen_s=8.0e-6, refit_s=2.5e-5, polish_s=5.0e-5, compile_s=7.0, operon_s=1.6e-4),
    "arithmetic/max": dict(screen_s=8.0e-6, refit_s=5.0e-5, polish_s=1.0e-4, compile_s=10.0, operon_s=1.6e-4),
    "functions/squares": dict(screen_s=1.0e-5, refit_s=2.5e-5, polish_s=5.0e-5, compile_s=8.0, operon_s=1.6e-4),
    "functions/max": dict(screen_s=1.0e-5, refit_s=5.0e-5, polish_s=1.0e-4, compile_s=11.0, operon_s=1.6e-4),
}
WEIGHT = 0.5            # a new measurement's weight in the kept rate
MIN_SECONDS = 1.0       # phases shorter than this measure the rate too coarsely to be kept
_LOCK = threading.Lock()
_COMPILE_EVENTS = ("/jax/core/compile/jaxpr_trace_duration", "/jax/core/compile/jaxpr_to_mlir_module_duration",
                   "/jax/core/compile/backend_compile_duration")
_compiling = [0.0]      # seconds of compilation in this process, by JAX's monitoring events
_listening = [False]
_compiled = set()       # the kinds of search whose programs this process has compiled


def rates_file() -> Path:
    from ..engine import paths

    return Path(os.environ.get("PIPELINE_RATES", paths.ROOT / ".cache" / "rates.json"))


def kind(codes, loss: str) -> str:
    """The kind of a search (module docstring) by its opcodes and loss."""
    from .grammar import ADD, CONST, DIV, MUL, SUB, VAR

    ops = "arithmetic" if set(codes) <= {VAR, CONST, ADD, SUB, MUL, DIV} else "functions"
    return f"{ops}/{'max' if loss.startswith('max') else 'squares'}"


def load() -> dict:
    """The kept rates of every kind (the defaults where none is kept, or the file is unreadable)."""
    out = {k: dict(v) for k, v in DEFAULTS.items()}
    try:
        kept = json.loads(rates_file().read_text())
    except (OSError, ValueError):
        return out
    for k, values in kept.items() if isinstance(kept, dict) else ():
        if k in out and isinstance(values, dict):
            for name, value in values.items():
                if name in out[k] and isinstance(value, (int, float)) and 0 < value < 1e6:
                    out[k][name] = float(value)
    return out


def record(kind_: str, screen: tuple | None = None, refit: tuple | None = None, polish: tuple | None = None,
           compile_s: float | None = None, operon: tuple | None = None) -> None:
    """Moves the kept rates of `kind_` halfway (WEIGHT) to a search's measurements: screen, refit,
    polish and operon as (units, seconds), compile_s its compilation where it compiled. Phases shorter than
    MIN_SECONDS are not kept. Written whole (a temporary file renamed), so that two searches at once
    leave a readable file."""
    with _LOCK:
        rates = load()
        entry = rates[kind_]
        for name, measured in (("screen_s", screen), ("refit_s", refit), ("polish_s", polish), ("operon_s", operon)):
            if measured and measured[0] > 0 and measured[1] >= MIN_SECONDS:
                entry[name] = (1 - WEIGHT) * entry[name] + WEIGHT * measured[1] / measured[0]
        if compile_s is not None and compile_s >= MIN_SECONDS:
            entry["compile_s"] = (1 - WEIGHT) * entry["compile_s"] + WEIGHT * compile_s
        path = rates_file()
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
            tmp.write_text(json.dumps(rates, indent=1) + "\n")
            os.replace(tmp, path)
        except OSError:
            pass                # a read-only checkout: the estimate keeps the defaults


def compiled(kind_: str) -> bool:
    """Whether this process has compiled a search of this kind (the next one compiles little)."""
    return kind_ in _compiled


def seconds(kind_: str, screen_units: float, refit_units: float, compiling: bool, rates: dict | None = None) -> float:
    """About how long a search of this kind and work (`search.screen_units`, `search.refit_units`)
    takes here (the kept rates), with its compilation if `compiling`."""
    rate = (rates or load())[kind_]
    return (rate["compile_s"] if compiling else 0.0) + screen_units * rate["screen_s"] + refit_units * rate["refit_s"]


def learn(timing: dict) -> None:
    """Keeps what a search measured (`search.search`'s `timing`: its kind, units and the seconds of its
    phases apart from compiling, and its compiling)."""
    compiling = timing["compile_seconds"]
    record(timing["kind"], screen=(timing["screen_units"], timing["screen_seconds"]),
           refit=(timing["refit_units"], timing["refit_seconds"]),
           compile_s=compiling if not compiled(timing["kind"]) else None)
    _compiled.add(timing["kind"])


def _listen(event: str, seconds: float, **_) -> None:
    if event in _COMPILE_EVENTS:
        _compiling[0] += seconds


def compile_seconds() -> float:
    """Seconds this process has spent compiling XLA programs since the listener started."""
    if not _listening[0]:
        import jax.monitoring

        jax.monitoring.register_event_duration_secs_listener(_listen)
        _listening[0] = True
    return _compiling[0]


class Stopwatch:
    """Laps of wall time, each with the seconds of it spent compiling XLA programs."""

    def __init__(self):
        self.started, self.compiling = time.perf_counter(), compile_seconds()

    def elapsed(self) -> tuple[float, float]:
        """(seconds, of which compiling) since the start or the last lap."""
        return time.perf_counter() - self.started, compile_seconds() - self.compiling

    def lap(self) -> tuple[float, float]:
        """`elapsed`, and a new lap starts."""
        out = self.elapsed()
        self.started, self.compiling = time.perf_counter(), compile_seconds()
        return out
