"""Dask-side pieces of sweeps: the local workers' plugin (Ctrl-C, a closed scheduler) and a filter for a race in distributed
(imports Dask: loaded only when a sweep uses Dask)."""
from __future__ import annotations

import logging
import signal
import threading
import traceback
from pathlib import Path
from typing import TYPE_CHECKING

from distributed.diagnostics.plugin import WorkerPlugin

if TYPE_CHECKING:
    from distributed import Worker


class QuietLocalWorker(WorkerPlugin):
    """A worker of the sweep's own LocalCluster ignores Ctrl-C and stays quiet when the cluster closes.

    A terminal sends Ctrl-C (SIGINT) to the whole process group. The sweep's own process
    handles it alone: it writes the finished rows and closes the cluster, without a
    KeyboardInterrupt traceback from every worker. A worker whose heartbeat falls between
    the scheduler's close and its own (on a loaded machine) would log the failed connection
    with a traceback; :class:`SchedulerGone` drops that record (the sweep's process, which
    holds the scheduler, reports what happened).
    """

    def setup(self, worker: Worker) -> None:
        """Ignore SIGINT in this worker process (its event loop runs in the main thread); install
        :class:`SchedulerGone` on ``distributed.worker``.

        Parameters
        ----------
        worker : distributed.Worker
            The worker being set up.
        """
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        log = logging.getLogger("distributed.worker")
        if not any(isinstance(f, SchedulerGone) for f in log.filters):
            log.addFilter(SchedulerGone())


class SchedulerGone(logging.Filter):
    """Drops a worker's "Failed to communicate with scheduler during heartbeat." record with an OSError.

    Installed only in the workers of a sweep's own LocalCluster (:class:`QuietLocalWorker`),
    whose scheduler lives and ends in the sweep's process. Every other record passes.

    Parameters
    ----------
    name : str
        As for :class:`logging.Filter`.
    """

    #: The start of the record's message (distributed/worker.py, ``Worker.heartbeat``).
    MESSAGE = "Failed to communicate with scheduler during heartbeat"

    def filter(self, record: logging.LogRecord) -> bool:
        """False for exactly that record: the heartbeat message with an OSError (no connection).

        Parameters
        ----------
        record : logging.LogRecord
            A log record.

        Returns
        -------
        bool
            Whether to keep it.
        """
        exc = record.exc_info[1] if record.exc_info else None
        return not (isinstance(exc, OSError) and record.getMessage().startswith(self.MESSAGE))


class SyncCancelRace(logging.Filter):
    """Drops the one log record of a race in ``distributed.utils.sync`` (distributed 2026.8).

    A Ctrl-C that lands while the client's event loop has not yet started the awaited call
    makes ``sync`` schedule a ``cancel`` callback that reads a variable the call has not set:
    tornado logs ``NameError: cannot access free variable 'future'`` with a traceback on
    ``tornado.application``. Nothing had started, so nothing is lost; the sweep's own
    "interrupted" line is the message. Every other record passes.

    Parameters
    ----------
    name : str
        As for :class:`logging.Filter` (the default ``""`` passes every logger's records to
        :meth:`filter`).
    """

    def filter(self, record: logging.LogRecord) -> bool:
        """False for exactly that record: a NameError raised in ``cancel`` of distributed/utils.py.

        Parameters
        ----------
        record : logging.LogRecord
            A log record.

        Returns
        -------
        bool
            Whether to keep it.
        """
        exc = record.exc_info[1] if record.exc_info else None
        if not isinstance(exc, NameError):
            return True
        last = traceback.extract_tb(exc.__traceback__)[-1:]   # the frame that raised it
        return not (last and last[0].name == "cancel" and Path(last[0].filename).match("distributed/utils.py"))


def drop_sync_cancel_race() -> None:
    """Install :class:`SyncCancelRace` on tornado's callback logger (once per process)."""
    log = logging.getLogger("tornado.application")
    if not any(isinstance(f, SyncCancelRace) for f in log.filters):
        log.addFilter(SyncCancelRace())
