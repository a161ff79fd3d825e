"""The one way the pipeline starts or reaches a Dask cluster (`pipeline sweep`'s points, `derive
--shader`'s library batch): a client of an existing cluster (`--scheduler ADDRESS`,
`--scheduler-file FILE`) or of a LocalCluster of this machine, one worker process per core, each
with one thread for XLA (the workers are the parallelism)."""

from __future__ import annotations

import logging
import os

from .config import ConfigError

# One thread per worker for XLA: the workers are the parallelism (one per core).
WORKER_ENV = {"XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
              "OMP_NUM_THREADS": "1"}


def client(scheduler: str | None = None, scheduler_file: str | None = None, workers: int | None = None):
    """(a Dask client, the LocalCluster it started or None): of an existing cluster where `scheduler`
    or `scheduler_file` names one (ConfigError, one line, where none answers), else of a LocalCluster
    of `workers` processes (default one per core). The caller closes both."""
    import dask
    from distributed import Client, LocalCluster

    dask.config.set({"distributed.logging.distributed": "error"})
    # The client's own errors (a lost scheduler) are the caller's to report, in one line.
    logging.getLogger("distributed.client").setLevel(logging.CRITICAL)
    if scheduler or scheduler_file:
        try:
            return Client(scheduler, scheduler_file=scheduler_file, timeout="3s"), None
        except (OSError, TimeoutError, ValueError) as e:
            where = scheduler or f"scheduler file {scheduler_file}"
            raise ConfigError(f"no Dask scheduler answers at {where}: {e}") from None
    cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                           dashboard_address=None, env=dict(WORKER_ENV), silence_logs=50)
    return Client(cluster), cluster
