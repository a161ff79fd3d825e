"""Publishing an output folder whole: written into a temporary folder beside it and swapped in by
one rename, under a lock per folder, so that a failed or killed write leaves the previous folder as
it was, a second writer waits for the first (and says so), and a later write sweeps what a killed
one left.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path

from .cache import temporary_folder


@contextlib.contextmanager
def output_lock(out_dir: Path, log):
    """An exclusive lock on `.<name>.lock` beside `out_dir`, held by the one run that writes it. A
    second run asking for it is told that it waits, and for what. The holder removes the lock file
    when it is done (nothing is left beside the folder); a waiter that then holds the lock of a
    removed file sees it (the path no longer names its file) and locks the path afresh."""
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    path = out_dir.parent / f".{out_dir.name}.lock"
    told = False
    while True:
        lock = open(path, "a")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if not told:
                log(f"{out_dir} is being written by another run: waiting for it to finish")
                told = True
            fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            current = os.stat(path).st_ino == os.fstat(lock.fileno()).st_ino
        except FileNotFoundError:
            current = False
        if current:
            break
        lock.close()
    if told:
        log(f"the other run has finished; this run goes on into {out_dir}")
    try:
        yield
    finally:
        path.unlink(missing_ok=True)        # still held: a waiter on this file re-locks the path
        lock.close()


def publish(out_dir: Path, stamp_key: str, log, write: Callable[[Path], str], locked: bool = False) -> None:
    """Writes `out_dir` through `write(tmp)` unless its stamp already equals `stamp_key`.

    Holds `output_lock(out_dir)` meanwhile (`locked`: the caller holds it already); any hidden
    `.<name>.*` folder found under the lock was left by a killed run, and is removed.
    """
    if out_dir.exists() and not out_dir.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, "a file, not a folder: give an output folder (the file is left as it is)",
                                 str(out_dir))
    with contextlib.nullcontext() if locked else output_lock(out_dir, log):
        for stale in out_dir.parent.glob(f".{out_dir.name}.*"):
            if stale.is_dir():
                shutil.rmtree(stale, ignore_errors=True)
        stamp = out_dir / ".stamp"
        if stamp.exists() and stamp.read_text() == stamp_key:
            log(f"outputs in {out_dir} are up to date")
            return
        start = time.perf_counter()
        tmp = temporary_folder(out_dir.parent, out_dir.name)
        try:
            summary = write(tmp)
            (tmp / ".stamp").write_text(stamp_key)
            old = out_dir.with_name(f".{out_dir.name}.old")
            if out_dir.exists():
                out_dir.rename(old)
            tmp.rename(out_dir)
            shutil.rmtree(old, ignore_errors=True)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        log(f"wrote {out_dir} ({summary}) in {time.perf_counter() - start:.1f} s")
