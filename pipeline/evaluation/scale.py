"""How many workers a batch gets, and retrying a batch whose dask worker was lost.

* :func:`workers_for`: ``parallel.n_jobs`` is capped by the cores this process
  may use (:func:`pipeline.evaluation.pool.worker_count`) and by the batch size,
  for single runs as for sweeps (``n_jobs=1000`` once started 243 processes for
  4 designs);
* :func:`retry_lost_workers`: on dask, a batch that fails because a worker
  died (``FutureCancelledError``, ``KilledWorker``, a lost connection) is sent
  again while the cluster still has workers; the run fails only when none
  remain. Results do not depend on which worker computed them, so a retried
  batch gives the same rows.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from concurrent.futures import CancelledError
from typing import TypeVar

from pipeline.evaluation.pool import worker_count

log = logging.getLogger(__name__)

T = TypeVar("T")

#: retries of one batch after a lost worker (each needs a surviving worker)
MAX_RETRIES = 3


def workers_for(n_jobs: int, batch: int) -> int:
    """Parallel chunks of a batch of ``batch`` designs: ``n_jobs`` capped by the cores and the batch."""
    return max(1, min(worker_count(int(n_jobs)), int(batch)))


def lost_worker(exc: BaseException) -> bool:
    """True for the errors dask raises when a worker (not the computation) failed."""
    module = type(exc).__module__ or ""
    return (
        isinstance(exc, CancelledError)
        or module.startswith("distributed")
        or type(exc).__name__ in ("FutureCancelledError", "KilledWorker", "CommClosedError")
    )


def dask_workers_left() -> int:
    """Workers of the current dask client (0 without one)."""
    try:
        from distributed import get_client

        return len(get_client().scheduler_info().get("workers", {}))
    except (ImportError, ValueError):
        return 0


def retry_lost_workers(batch: Callable[[], T], workers_left: Callable[[], int] | None = None) -> T:
    """``batch()``, sent again after a lost worker while workers remain (at most :data:`MAX_RETRIES`;
    ``workers_left``: how many remain, default :func:`dask_workers_left`)."""
    for attempt in range(MAX_RETRIES + 1):
        try:
            return batch()
        except Exception as exc:  # noqa: BLE001 - only a lost worker is retried; the rest re-raised
            if not lost_worker(exc) or attempt == MAX_RETRIES:
                raise
            left = (workers_left or dask_workers_left)()
            if left == 0:
                raise
            log.warning(
                "evaluate: a dask worker was lost (%s); batch sent again to the %d left", type(exc).__name__, left
            )
    raise AssertionError("unreachable")
