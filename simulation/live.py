"""Live view: serve a run over the Foxglove WebSocket protocol while it is simulated.

The server is foxglove-sdk's (``foxglove.start_server``), on a context of its own, so it sees
only these channels, on a loopback port of its own behind a :class:`~.ws_bridge.SubprotocolBridge`
on the public port, which also lets in the viewers that offer the protocol's former name
``foxglove.websocket.v1`` (Foxglove Studio 1.48, Lichtblick). It carries the same topics, schemas
and message bytes as the log (:mod:`.mcap_writer`): the per-step channels at a reduced rate
(default 50 Hz, plenty for a plot), ``/scene``, ``/tf`` and ``/tracking`` at the scene rate,
``/scene/fixed`` once (and again whenever a viewer subscribes to it),
``/margins/cond`` at the log's cond rate. Messages go out paced to the simulated time (``speed``
simulated seconds per wall second) from a thread of their own; its queue is short, so a
simulation that runs faster than that waits for the view. A client that stops reading never
slows the run: the SDK drops its oldest messages (and disconnects it when even its control queue
is full), the bridge drops it after :data:`~.ws_bridge.STALL_TIMEOUT` seconds without progress.
"""
from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np

from coordarm.symbolic import ConfigError, CoordinatingController
from coordarm.symbolic.checks import is_real

from .log_schemas import CDR_HEADER, FIXED_TOPIC, FOXGLOVE_CHANNELS, PER_STEP, foxglove_schema_bytes, numeric_channels
from .log_layout import PLANAR, ChainLayout, layout_of_chain
from .mcap_file import Worker
from .cond_channel import cond_plan, cond_values
from .mcap_writer import SCENE_RATE, log_time_ns, steps_between
from .run import Run
from .scenario import Scenario
from .scene_kind import scene_builder
from .ws_bridge import SubprotocolBridge

#: Default rate of the per-step channels on the live view [Hz].
LIVE_RATE = 50.0

#: :meth:`LiveView.wait_for_client` returns once no new subscription came for this long [s] (a viewer
#: subscribes panel by panel within a few hundred milliseconds of connecting).
SUBSCRIPTIONS_SETTLE = 1.0


def sdk_channels(context: Any, links: int, scenes: bool = True, layout: ChainLayout = PLANAR,
                 rail: bool = False) -> dict[str, Any]:
    """foxglove-sdk channels on ``context`` for the log's topics: the per-step ones and, if ``scenes``,
    ``/margins/cond``, ``/tracking``, ``/scene`` and ``/tf`` (same schemas and encodings as the log; keys as
    in the log).

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
    rail : bool
        The chain's base moves on a rail (``q``, ``u`` hold ``d``, ``d_dot`` first; as in the log).

    Returns
    -------
    dict of str to foxglove.Channel
        The channels by log key.
    """
    import foxglove

    numeric = numeric_channels(links, rail, layout)
    out = {}
    for key in (*PER_STEP, "cond", "tracking") if scenes else PER_STEP:
        ch = numeric[key]
        schema = foxglove.Schema(name=ch.schema_name, encoding="ros2msg", data=ch.schema_text().encode())
        out[key] = foxglove.Channel(ch.topic, schema=schema, message_encoding="cdr", context=context)
    for key, (topic, name) in FOXGLOVE_CHANNELS.items() if scenes else ():
        schema = foxglove.Schema(name=name, encoding="jsonschema", data=foxglove_schema_bytes(name))
        out[key] = foxglove.Channel(topic, schema=schema, message_encoding="json", context=context)
    return out


def subscription_listener() -> Any:
    """A ``foxglove.websocket.ServerListener`` that records the time of the latest subscription.

    It subclasses the SDK's listener, so every callback the server makes (``on_unsubscribe`` at each
    disconnect, ...) exists; ``event`` is set at the first subscription, ``last`` holds the
    ``time.monotonic()`` of the latest one, ``fixed`` is set at each subscription to ``/scene/fixed`` (its
    one message is then sent again).

    Returns
    -------
    foxglove.websocket.ServerListener
        The listener.
    """
    from foxglove.websocket import ServerListener

    class Subscriptions(ServerListener):
        def __init__(self) -> None:
            self.event = threading.Event()
            self.fixed = threading.Event()
            self.last = 0.0

        def on_subscribe(self, client: Any, channel: Any) -> None:
            if channel.topic == FIXED_TOPIC:
                self.fixed.set()
            self.last = time.monotonic()
            self.event.set()

    return Subscriptions()


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
    cond_rate : float, optional
        Rate of ``/margins/cond`` [Hz], 0 = off (default: the log's default, :func:`~.cond_channel.cond_plan`).
    frames : {"ends", "all"}
        The frames of ``/tf``: ``base`` and ``tip``, or one per link (as the log's).
    cond_exact : bool
        Serve the exact 2-norm condition number instead of the 1-norm one (as the log's ``cond_exact``).

    Raises
    ------
    ConfigError
        A rate or speed that is not a positive number, or the server cannot listen on ``port``.
    """

    def __init__(self, scenario: Scenario, ctrl: CoordinatingController | None = None, *, port: int = 8765,
                 host: str = "127.0.0.1", speed: float = 1.0, rate: float = LIVE_RATE,
                 scene_rate: float = SCENE_RATE, cond_rate: float | None = None, frames: str = "ends",
                 cond_exact: bool = False) -> None:
        import foxglove
        from foxglove.websocket import Capability

        ctrl = ctrl or scenario.controller()
        if not is_real(speed) or not speed > 0 or not np.isfinite(speed):
            raise ConfigError(f"live speed: need a positive number of simulated seconds per second, got {speed!r}")
        self.speed = float(speed)
        self.every = steps_between(rate, scenario.step, "live rate")
        self.scene_every = steps_between(scene_rate, scenario.step, "scene_rate")
        self.origin = min(0.0, scenario.t0)
        self.scene = scene_builder(ctrl, scenario.obstacles, getattr(scenario.physical(ctrl.chain), "radius", None),
                                   frames)
        layout = layout_of_chain(ctrl.chain)
        self.numeric = numeric_channels(ctrl.chain.m, ctrl.chain.rail, layout)
        cond_rate, self.cond_exact = cond_plan(ctrl, cond_rate, cond_exact, layout is PLANAR)
        self.cond_every = steps_between(cond_rate, scenario.step, "cond_rate") if cond_rate else 0
        self.ctrl = ctrl
        self.context = foxglove.Context()
        self._listener = subscription_listener()
        try:
            self.server = foxglove.start_server(name=f"coordarm {scenario.name}", host="127.0.0.1", port=0,
                                                context=self.context, server_listener=self._listener,
                                                capabilities=[Capability.Time])
        except Exception as exc:  # foxglove raises its own error types
            raise ConfigError(f"--live: cannot start the live server: {exc}") from None
        try:
            self.bridge = SubprotocolBridge(("127.0.0.1", self.server.port), host=host, port=port)
        except (OSError, OverflowError) as exc:
            self.server.stop()
            raise ConfigError(f"--port {port}: cannot start the live server on {host}: {exc}") from None
        self.channels = sdk_channels(self.context, ctrl.chain.m, layout=layout, rail=ctrl.chain.rail)
        self.host = host
        self._seen = 0
        self._clock: tuple[float, int] | None = None  # (wall time, log time) of the first message
        self._drop = False
        self._fixed: bytes | None = None     # the /scene/fixed message, sent again to each new subscriber
        self._worker = Worker(self._publish, "coordarm-live", 4)

    @property
    def port(self) -> int:
        """The port the server listens on (the bridge's)."""
        return self.bridge.port

    @property
    def url(self) -> str:
        """The server's address, e.g. ``ws://127.0.0.1:8765``."""
        return f"ws://{self.host}:{self.port}"

    def wait_for_client(self, timeout: float | None = None, settle: float = SUBSCRIPTIONS_SETTLE) -> bool:
        """Block until a client subscribed and then ``settle`` seconds passed without a new subscription.

        A viewer subscribes to the topics of its open panels one after another as it connects; waiting
        for them to settle lets every panel of an already loaded layout see the run from its start.

        Parameters
        ----------
        timeout : float or None
            Longest wait for the first subscription [s] (None: no limit).
        settle : float
            Quiet time after the latest subscription [s].

        Returns
        -------
        bool
            A client subscribed.
        """
        if not self._listener.event.wait(timeout):
            return False
        while (quiet := time.monotonic() - self._listener.last) < settle:
            time.sleep(settle - quiet)
        return True

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
        if self.cond_every:   # as the log computes it (mcap_writer.RunLogger)
            ks = np.flatnonzero(g % self.cond_every == 0)
            if len(ks):
                for k, value in zip(ks, cond_values(self.ctrl, self.cond_exact, part.q[ks], part.t[ks])):
                    out.append((int(log_time_ns(part.t[k], self.origin)), "cond",
                                CDR_HEADER + np.array([part.t[k], value], "<f8").tobytes()))
        out.sort(key=lambda item: item[0])
        last = None
        for n, key, data in out:
            if self._drop:
                return
            if n != last:
                self._pace(n)
                self.server.broadcast_time(n)
                last = n
            if key == "fixed":
                self._fixed = bytes(data)
                self._listener.fixed.clear()
            elif self._fixed is not None and self._listener.fixed.is_set():   # a viewer subscribed since
                self._listener.fixed.clear()
                self.channels["fixed"].log(self._fixed, log_time=n)
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
        self.server.stop()    # closes its connections (the bridge passes the closing handshake on)
        self.bridge.close()

    def __enter__(self) -> "LiveView":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        self.close(drop=exc_type is not None)
        return False
