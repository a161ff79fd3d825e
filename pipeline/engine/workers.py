"""The worker processes a run starts (the figure drawer's, the derive search's): started with
"spawn", born ignoring SIGINT, ending with their parent whatever ends it."""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor

from . import toolchains

PR_SET_PDEATHSIG = 1     # Linux prctl: a signal the kernel sends when the parent dies


def _watch_parent(parent: int) -> None:
    while True:
        time.sleep(0.5)
        if os.getppid() != parent:
            os._exit(1)


def worker_start(parent: int) -> None:
    """A worker's first act: it ends with the run, whatever ends the run.

    An interrupt is the parent's to handle (Ctrl-C reaches the whole process group), so the worker
    ignores SIGINT; the parent's death, SIGKILL included, ends the worker: by the kernel's death
    signal on Linux, and, everywhere, by a thread that notices the worker has been reparented."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    toolchains.prepare()        # the worker finds its tools as the run did, whoever started the run
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def ignoring_sigint(start):
    """`start()` with SIGINT ignored meanwhile: a worker process started in it is born ignoring
    SIGINT (an ignored signal stays ignored across exec), so a Ctrl-C during its start-up, before
    `worker_start` runs, cannot end it with a traceback. Only the main thread may change signals."""
    try:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:
        return start()
    try:
        return start()
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def _main_script_hidden():
    """Meanwhile a spawned worker does not run the parent's main script again: multiprocessing runs a
    script started by path (`python job.py`) in each spawned child as `__mp_main__`, and with it
    whatever the script calls outside an `if __name__ == "__main__":` guard (`pipeline.derive(...)`).
    The workers run the package's functions only, which they import. (A main module started by name,
    `python -m pipeline`, is imported by name, its guard there.)"""
    main = sys.modules.get("__main__")
    if main is None or getattr(main, "__spec__", None) is not None or "__file__" not in vars(main):
        yield
        return
    path = main.__file__
    del main.__file__
    try:
        yield
    finally:
        main.__file__ = path


def submitted(pool: ProcessPoolExecutor, function, *args):
    """`pool.submit(function, *args)`, a worker it starts born ignoring SIGINT (`ignoring_sigint`) and
    without the parent's main script (`_main_script_hidden`)."""
    with _main_script_hidden():
        return ignoring_sigint(lambda: pool.submit(function, *args))


def may_start_processes() -> bool:
    """Whether this process may start a child: a daemonic one (a Dask worker under its nanny) may not."""
    return not multiprocessing.current_process().daemon


def cores() -> int:
    """The processor cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def spawned_pool(workers: int) -> ProcessPoolExecutor:
    """A pool of `workers` spawned processes, each started by `worker_start`."""
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=worker_start, initargs=(os.getpid(),))


def stop(pool: ProcessPoolExecutor) -> None:
    """Ends a pool's workers at once (SIGKILL), where the run stops on an interrupt or an error: what
    they compute is no longer wanted, and an orderly shutdown would wait for it (or, interrupted
    while a worker held the pool's queue, forever). Python 3.11's pool has no public way to do it:
    its processes are read from `_processes`."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        process.kill()
    for process in processes:
        process.join(timeout=10)
    pool.shutdown(wait=False, cancel_futures=True)
