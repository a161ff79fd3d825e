"""Publishing an output folder whole: written into a temporary folder beside it and swapped in by
one rename, under a lock per folder, so that a failed or killed write leaves the previous folder as
it was, two writers leave one complete copy, and a later write sweeps what a killed one left.
"""

from __future__ import annotations

import fcntl
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path


def publish(out_dir: Path, stamp_key: str, log, write: Callable[[Path], str]) -> None:
    """Writes `out_dir` through `write(tmp)` unless its stamp already equals `stamp_key`.

    Holds an exclusive lock on `.<name>.lock` beside it meanwhile; any hidden `.<name>.*` folder
    found under the lock was left by a killed run, and is removed.
    """
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    with open(out_dir.parent / f".{out_dir.name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        for stale in out_dir.parent.glob(f".{out_dir.name}.*"):
            if stale.is_dir():
                shutil.rmtree(stale, ignore_errors=True)
        stamp = out_dir / ".stamp"
        if stamp.exists() and stamp.read_text() == stamp_key:
            log(f"outputs in {out_dir} are up to date")
            return
        start = time.perf_counter()
        tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp.", dir=out_dir.parent))
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
