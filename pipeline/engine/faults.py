"""What a run that cannot finish says, and the exit code it ends with (the table of docs/engine.md).

0 done; 1 a check failed or a solver did not converge; 2 bad input (config, arguments, a CSV);
3 an environment fault (a full disk, a file size limit, a path that is a file, no permission);
124 stopped by its own `--timeout`; 130 interrupted (Ctrl-C or SIGTERM). Each is one line naming
the cause and the remedy.
"""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import sys
from pathlib import Path

EXIT_DONE, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_ENVIRONMENT, EXIT_TIMED_OUT, EXIT_INTERRUPTED = 0, 1, 2, 3, 124, 130


class EnvironmentFault(Exception):
    """The machine, not the input: a path that cannot be used, a full disk. The CLI exits with 3."""


class Interrupted(BaseException):
    """SIGINT or SIGTERM, raised in the main thread by `check_interrupted`. The CLI exits with 130."""

    def __init__(self, signal_name: str):
        super().__init__(signal_name)
        self.signal_name = signal_name


class TimedOut(BaseException):
    """The run's `--timeout` has passed (`stop_after`). The CLI exits with 124."""

    def __init__(self, seconds: float):
        super().__init__(seconds)
        self.seconds = seconds


_received: list[str] = []


def _record(signum, frame):
    _received.append(signal.Signals(signum).name)


def stop_on_signals() -> None:
    """SIGINT and SIGTERM are recorded, and `check_interrupted` raises `Interrupted` at the next
    point the run passes (the main thread passes one at least twice a second while stages compute).

    The handler does not raise itself: it runs wherever the main thread is, and where that is a
    callback whose exceptions are ignored (JAX's garbage-collection hook), the exception would be
    lost, with a traceback printed."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _record)


def _raise(signum, frame):
    raise Interrupted(signal.Signals(signum).name)


def raise_on_signals() -> None:
    """SIGINT and SIGTERM raise `Interrupted` at once: for a command that computes in the main
    thread (`regress`), where no check point would be passed."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _raise)


RAISE_AGAIN_SECONDS = 0.2


def stop_after(seconds: float | None) -> None:
    """Raises `TimedOut` in the main thread once `seconds` of wall time have passed (None: never): a
    hard limit on a run, which a run that finishes never notices (its work is planned, not timed).
    The signal lands wherever the main thread is; where that is a callback whose exceptions are
    ignored (JAX's garbage-collection hook), the exception is lost: it is raised again every
    RAISE_AGAIN_SECONDS until it reaches the command (which then exits at once)."""
    if seconds is None:
        return
    default_hook = sys.unraisablehook

    def fire(signum, frame):
        signal.setitimer(signal.ITIMER_REAL, RAISE_AGAIN_SECONDS)
        raise TimedOut(seconds)

    def unraisable(what):           # (the lost one is raised again: no traceback of it on stderr)
        if not isinstance(what.exc_value, TimedOut):
            default_hook(what)

    sys.unraisablehook = unraisable

    signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)


def check_interrupted() -> None:
    """Raises `Interrupted` if SIGINT or SIGTERM has arrived."""
    if _received:
        raise Interrupted(_received[-1])


def describe(e: OSError) -> str:
    """One line for an operating-system error: what failed, where, and what to do."""
    where = f" ({e.filename})" if e.filename else ""
    if e.errno in (errno.ENOSPC, errno.EDQUOT):
        return (f"no space left on the device{where}: free some, or point PIPELINE_CACHE_DIR and "
                "PIPELINE_OUTPUTS_DIR at a disk with room (`pipeline cache --prune` frees cache entries)")
    if e.errno == errno.EFBIG:
        return f"a file reached the size limit{where} (`ulimit -f`): raise the limit and rerun"
    if e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return (f"permission denied{where}: make the folder writable, or point PIPELINE_CACHE_DIR and "
                "PIPELINE_OUTPUTS_DIR at folders you can write")
    if e.errno in (errno.ENOTDIR, errno.EEXIST, errno.EISDIR):
        return f"a path is a file where a folder is needed, or the reverse{where}: move it aside and rerun"
    return f"{e.strerror or e}{where}"


@contextlib.contextmanager
def writing(shown: Path):
    """Writing one file, which a message names as `shown` (where it lands, not the temporary folder
    it is written in): an OSError raised meanwhile is raised again naming it, with its cause where
    the writer gave none (a short write: "N requested and M written", as numpy says it) read off the
    device (no room left: ENOSPC) or the process's file-size limit (EFBIG)."""
    try:
        yield
    except OSError as e:
        code = e.errno
        if code is None:
            import resource
            import shutil

            folder = next((p for p in Path(shown).parents if p.exists()), Path("."))
            limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
            code = (errno.ENOSPC if shutil.disk_usage(folder).free < 1 << 20 else
                    errno.EFBIG if limit != resource.RLIM_INFINITY else None)
        raise OSError(code, e.strerror or str(e), str(shown)) from None


def check_folder(path: Path, what: str) -> None:
    """Raises `EnvironmentFault` unless `path` is a writable folder or can be created as one."""
    path = Path(path)
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        blocker = "is a file" if existing == path else f"cannot be created: '{existing}' is a file"
        raise EnvironmentFault(f"{what} '{path}' {blocker}, not a folder: point it at a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise EnvironmentFault(f"{what} '{path}' is not writable ('{existing}'): point it at a folder you can write")
