# SPDX-License-Identifier: BSD-3-Clause
"""The Dask client a batch runs on: an existing scheduler's, or a LocalCluster of single-threaded workers."""

from __future__ import annotations

import contextlib
import os
from typing import Optional

# Dask's housekeeping, made rarer for a batch's long single-threaded tasks. With the defaults (an event-loop tick
# every 20 ms, system and memory monitors every 0.5 s and 0.1 s, a statistical profiler sampling each worker every
# 10 ms) the scheduler's and nannies' event loop used 0.7 s of CPU per 40-task batch of 400 KITTI frames, and on a
# machine with as many workers as cores that time is taken from the workers (README, "Drives").
LOCAL_CLUSTER_CONFIG = {"distributed.admin.tick.interval": "500ms", "distributed.admin.system-monitor.interval": "5s",
                        "distributed.worker.memory.monitor-interval": "1s", "distributed.worker.profile.enabled": False}


def local_cluster(workers: int):
    """A LocalCluster of ``workers`` single-threaded worker processes with LOCAL_CLUSTER_CONFIG. The worker
    processes ignore SIGINT: a terminal's Ctrl-C reaches the whole process group, and each worker printed a
    KeyboardInterrupt traceback; the client (main) stops them."""
    import dask
    from distributed import LocalCluster

    with dask.config.set(LOCAL_CLUSTER_CONFIG), _sigint_ignored():  # the nannies hand both to their workers
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)


@contextlib.contextmanager
def _sigint_ignored():
    """SIGINT ignored meanwhile (in the main thread only: elsewhere signals cannot be set, nor arrive). A process
    started meanwhile keeps ignoring it (Python installs its KeyboardInterrupt handler only over the default)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def connect(workers: Optional[int], scheduler: Optional[str], timeout_s: float = 10.0):
    """A Dask client: to the scheduler at ``scheduler``, else a LocalCluster of ``workers`` single-threaded
    processes (default: one per core)."""
    from distributed import Client

    if scheduler:
        try:
            return Client(scheduler, timeout=f"{timeout_s}s")
        except (OSError, TimeoutError) as err:
            raise RuntimeError(f"{scheduler}: cannot reach the Dask scheduler ({err})") from None
    return Client(local_cluster(workers or os.cpu_count() or 1))
