"""Dask worker plugin of local sweeps (imports Dask: loaded only when a local cluster starts)."""
from __future__ import annotations

import signal
import threading

from distributed.diagnostics.plugin import WorkerPlugin


class IgnoreCtrlC(WorkerPlugin):
    """A local worker ignores Ctrl-C (SIGINT), which a terminal sends to the whole process group.

    The sweep's own process handles it alone: it writes the finished rows and closes the
    cluster, without a KeyboardInterrupt traceback from every worker.
    """

    def setup(self, worker) -> None:
        """Ignore SIGINT in this worker process (its event loop runs in the main thread).

        Parameters
        ----------
        worker : distributed.Worker
            The worker being set up.
        """
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
