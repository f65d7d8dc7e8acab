"""Live view: serve a run over the Foxglove WebSocket protocol while it is simulated.

The server is foxglove-sdk's (``foxglove.start_server``), on a context of its own, so it sees
only these channels. It carries the same topics, schemas and message bytes as the log
(:mod:`.mcap_writer`): the per-step channels at a reduced rate (default 50 Hz, plenty for a
plot), ``/scene``, ``/tf`` and ``/tracking`` at the scene rate. Messages go out paced to the
simulated time (``speed`` simulated seconds per wall second) from a thread of their own; its
queue is short, so a simulation that runs faster than that waits for the view.
"""
from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np

from coordarm.symbolic import ConfigError, CoordinatingController
from coordarm.symbolic.checks import is_real

from .log_schemas import CDR_HEADER, FOXGLOVE_CHANNELS, PER_STEP, foxglove_schema_bytes, numeric_channels
from .log_layout import PLANAR, ChainLayout, layout_of_chain
from .mcap_file import Worker
from .mcap_writer import SCENE_RATE, log_time_ns, steps_between
from .run import Run
from .scenario import Scenario
from .scene3d import scene_builder

#: Default rate of the per-step channels on the live view [Hz].
LIVE_RATE = 50.0


def sdk_channels(context: Any, links: int, scenes: bool = True, layout: ChainLayout = PLANAR) -> dict[str, Any]:
    """foxglove-sdk channels on ``context`` for the log's topics: the per-step ones and, if ``scenes``,
    ``/tracking``, ``/scene`` and ``/tf`` (same schemas and encodings as the log; keys as in the log).

    Parameters
    ----------
    context : foxglove.Context
        The SDK context the channels belong to.
    links : int
        Number of links (sets the array lengths of the schemas).
    scenes : bool
        Also the ``/tracking``, ``/scene`` and ``/tf`` channels.
    layout : ChainLayout
        The chain kind's layout (:data:`~.log_layout.PLANAR` or :data:`~.log_layout.SPATIAL`).

    Returns
    -------
    dict of str to foxglove.Channel
        The channels by log key.
    """
    import foxglove

    numeric = numeric_channels(links, layout=layout)
    out = {}
    for key in (*PER_STEP, "tracking") if scenes else PER_STEP:
        ch = numeric[key]
        schema = foxglove.Schema(name=ch.schema_name, encoding="ros2msg", data=ch.schema_text().encode())
        out[key] = foxglove.Channel(ch.topic, schema=schema, message_encoding="cdr", context=context)
    for key, (topic, name) in FOXGLOVE_CHANNELS.items() if scenes else ():
        schema = foxglove.Schema(name=name, encoding="jsonschema", data=foxglove_schema_bytes(name))
        out[key] = foxglove.Channel(topic, schema=schema, message_encoding="json", context=context)
    return out


class _Subscribed:
    """A ``foxglove.websocket.ServerListener`` that sets an event at the first subscription."""

    def __init__(self) -> None:
        self.event = threading.Event()

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self.event.set()


class LiveView:
    """A Foxglove WebSocket server showing a run as it is simulated; pass :meth:`on_chunk` to ``simulate``.

    Use as a context manager: leaving the block sends what is still queued (paced) and stops
    the server, unless the block ends with an exception (then the rest is dropped).

    Parameters
    ----------
    scenario : Scenario
        The scenario being run.
    ctrl : CoordinatingController, optional
        Its controller (default ``scenario.controller()``).
    port : int
        TCP port (0: any free port, see :attr:`port`).
    host : str
        Address to listen on.
    speed : float
        Simulated seconds shown per wall-clock second (1 = real time).
    rate : float
        Samples per simulated second on the per-step channels [Hz].
    scene_rate : float
        Rate of ``/scene``, ``/tf`` and ``/tracking`` [Hz].

    Raises
    ------
    ConfigError
        A rate or speed that is not a positive number, or the server cannot listen on ``port``.
    """

    def __init__(self, scenario: Scenario, ctrl: CoordinatingController | None = None, *, port: int = 8765,
                 host: str = "127.0.0.1", speed: float = 1.0, rate: float = LIVE_RATE,
                 scene_rate: float = SCENE_RATE) -> None:
        import foxglove
        from foxglove.websocket import Capability

        ctrl = ctrl or scenario.controller()
        if not is_real(speed) or not speed > 0 or not np.isfinite(speed):
            raise ConfigError(f"live speed: need a positive number of simulated seconds per second, got {speed!r}")
        self.speed = float(speed)
        self.every = steps_between(rate, scenario.step, "live rate")
        self.scene_every = steps_between(scene_rate, scenario.step, "scene_rate")
        self.origin = min(0.0, scenario.t0)
        self.scene = scene_builder(ctrl, scenario.obstacles, getattr(scenario.physical(ctrl.chain), "radius", None))
        layout = layout_of_chain(ctrl.chain)
        self.numeric = numeric_channels(ctrl.chain.m, layout=layout)
        self.context = foxglove.Context()
        self._listener = _Subscribed()
        try:
            self.server = foxglove.start_server(name=f"coordarm {scenario.name}", host=host, port=port,
                                                context=self.context, server_listener=self._listener,
                                                capabilities=[Capability.Time])
        except Exception as exc:  # foxglove raises its own error types for a port in use, a bad host, ...
            raise ConfigError(f"--port {port}: cannot start the live server on {host}: {exc}") from None
        self.channels = sdk_channels(self.context, ctrl.chain.m, layout=layout)
        self.host = host
        self._seen = 0
        self._clock: tuple[float, int] | None = None  # (wall time, log time) of the first message
        self._drop = False
        self._worker = Worker(self._publish, "coordarm-live", 4)

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return self.server.port

    @property
    def url(self) -> str:
        """The server's address, e.g. ``ws://127.0.0.1:8765``."""
        return f"ws://{self.host}:{self.port}"

    def wait_for_client(self, timeout: float | None = None) -> bool:
        """Block until a client subscribes to a channel (or ``timeout`` [s] passes); True if one did.

        Parameters
        ----------
        timeout : float or None
            Longest wait [s] (None: no limit).

        Returns
        -------
        bool
            A client subscribed.
        """
        return self._listener.event.wait(timeout)

    def on_chunk(self, part: Run) -> None:
        """Queue a block of consecutive steps (blocks while the view is more than a few blocks behind).

        Parameters
        ----------
        part : Run
            The steps (rows in time order).

        Raises
        ------
        BaseException
            The first error of the sending thread, re-raised.
        """
        if self._worker.error is not None:
            raise self._worker.error
        self._worker.put(part)

    def _publish(self, part: Run) -> None:
        if self._drop:
            return
        g = self._seen + np.arange(len(part.t))
        self._seen += len(part.t)
        self.scene.advance(part)
        rows = np.flatnonzero(g % self.every == 0)
        out = []
        ns = log_time_ns(part.t[rows], self.origin).tolist()
        for key in PER_STEP:
            ch = self.numeric[key]
            data = np.empty((len(rows), ch.width), "<f8")
            ch.fill(data, part, rows)
            out += [(n, key, CDR_HEADER + row.tobytes()) for n, row in zip(ns, data)]
        ks = np.flatnonzero(g % self.scene_every == 0)
        out += [(n, key, data) for key, n, data in self.scene.messages(part, ks, log_time_ns(part.t[ks], self.origin))]
        out.sort(key=lambda item: item[0])
        last = None
        for n, key, data in out:
            if self._drop:
                return
            if n != last:
                self._pace(n)
                self.server.broadcast_time(n)
                last = n
            self.channels[key].log(data, log_time=n)

    def _pace(self, ns: int) -> None:
        """Wait until wall time reaches log time ``ns`` at :attr:`speed`."""
        now = time.monotonic()
        if self._clock is None:
            self._clock = (now, ns)
        due = self._clock[0] + (ns - self._clock[1]) * 1e-9 / self.speed
        if due > now:
            time.sleep(due - now)

    def close(self, drop: bool = False) -> None:
        """Send what is queued (or drop it if ``drop``), then stop the server.

        Parameters
        ----------
        drop : bool
            Discard the queued blocks instead of sending them.
        """
        self._drop = self._drop or drop
        self._worker.stop()
        self.server.stop()

    def __enter__(self) -> "LiveView":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        self.close(drop=exc_type is not None)
        return False
