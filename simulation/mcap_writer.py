"""Log a run to MCAP: numeric channels in CDR, a Foxglove scene, the scenario and the outcome.

Channels (timestamps: ns of simulated time)

* ``/joint_state`` (``t``, ``q``, ``u``), ``/task_state`` (``t``, ``s``, ``v_star``, ``e``),
  ``/margins`` (``t``, ``link_margins`` of links 2..m, ``longitudinal``): every logged step;
* ``/margins/cond``: condition number of the decoupling matrix: by default its 1-norm condition
  number, exact up to 256 joints (1 Hz) and above that an O(m) estimate (0.5 Hz; a lower bound,
  :mod:`coordarm.symbolic.cond_estimate`), with
  ``cond_exact=True`` the exact 2-norm one (an SVD, O(m^3)); the ``run`` metadata's ``cond`` says which;
* ``/scene``: ``foxglove.SceneUpdate`` JSON (chain, curve, the end point's target, obstacles),
  ``/tf``: ``foxglove.FrameTransforms`` JSON (``base`` and ``tip``, or a frame per link) and
  ``/tracking`` (``s`` and its target, ``max|e|``, the smallest link margin, ``|u|``), ~20 Hz
  (:mod:`.scene`).

A spatial chain (universal joints) has the same per-step topics with fields of its own
(:data:`~.log_schemas.SPATIAL_CHANNEL_LAYOUT`), ``chain_kind = "universal"`` in the ``run`` metadata,
``/margins/cond`` off by default and no scene until the scene builder draws one.

Metadata records: ``scenario`` (the whole scenario JSON), ``build`` (code hash, versions),
``run`` (command line, start time, host) and, when the run ends in any way short of a kill,
``outcome``; each carries the SHA-256 of its entries (key ``sha256``), checked by
:func:`analysis.replay.load`. Chunks are built with numpy for a whole block of steps at once,
compressed with lz4 (default) or zstd (or stored as they are), and pushed to the operating system every half second
(also while the simulation is busy with a long block), with at most two blocks queued, so a
killed run loses at most the last second. The log is written as ``<name>.partial.mcap``
(locked against a second writer) and renamed to its name when it is closed; a killed run
leaves the ``.partial.mcap`` file, which :func:`analysis.replay.load` reads. With
``threaded=True`` this runs on worker threads (compression and a compiled simulation release
the GIL), which overlaps logging with the simulation when a core is free.
"""
from __future__ import annotations

import json
import platform
import signal
import sys
import threading
import time
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from coordarm.symbolic import ConfigError, CoordinatingController, LogError
from coordarm.symbolic.digests import sha256
from coordarm.symbolic.interrupts import interruption
from coordarm.symbolic.task import is_built_in

from .choices import DEFAULT_COMPRESSION, Backend
from .cond_channel import COND_KINDS, COND_LINK_LIMIT, COND_RATE, cond_plan, cond_values  # noqa: F401 (re-exported)
from .cond_channel import default_cond_rate  # noqa: F401 (re-exported)
from .every_step import governed_steps
from .log_layout import PLANAR, layout_of_chain, partial_path
from .log_schemas import (CDR_HEADER, FOXGLOVE_CHANNELS, PER_STEP, NumericChannel, foxglove_schema_bytes,
                          numeric_channels)
from .host import host_name, host_platform, installed_version
from .outcome import outcome_of
from .rates import MOST_STEPS_BETWEEN, steps_between  # noqa: F401 (re-exported)
from .record_packing import RecordPacker
from .recycled_arrays import RecycledArrays
from .mcap_file import COMPRESSIONS, MESSAGE_HEADER_DTYPE, MESSAGE_HEADER_SIZE, McapFile, Worker, message_records
from .run import Run
from .scenario import Scenario
from .scene_kind import scene_builder

#: Wall time between pushes of the log to the operating system [s] (a kill loses at most ~2x this).
FLUSH_INTERVAL = 0.5


#: Default uncompressed chunk size [bytes]: zstd level 1 once compressed a 64-link run's 1 MiB chunks about
#: 1.5x faster than 256 KiB ones (benchmarks/RESULTS_logging.md); with zstandard 0.25 and lz4 4.4 the
#: full-rate log of 64 links takes the same time in 256 KiB, 1 MiB or 4 MiB chunks (RESULTS.md, issue 24).
CHUNK_SIZE = 1 << 20

#: Default rate of the scene channels [Hz] (``/margins/cond``: :data:`~.cond_channel.COND_RATE`).
SCENE_RATE = 20.0


def log_time_ns(t: float | np.ndarray, origin: float) -> np.ndarray:
    """Log times [ns] of simulated times ``t`` [s]: nanoseconds since ``origin`` (<= every t).

    Parameters
    ----------
    t : float or (N,) ndarray
        Simulated times [s].
    origin : float
        The log's time origin [s]; a ``t`` before it wraps around (unsigned result).

    Returns
    -------
    uint64 ndarray or numpy.uint64
        Rounded nanoseconds, of the shape of ``t`` (a numpy scalar for a float).
    """
    return np.round((np.asarray(t) - origin) * 1e9).astype(np.uint64)


def code_hash() -> str:
    """SHA-256 over the Python sources of the ``symbolic`` and ``simulation`` packages (sorted by path),
    remembered while they are unchanged (:func:`~coordarm.generated.code_identity.sources_digest`).

    Returns
    -------
    str
        The digest, 64 hex digits (``generated`` and ``analysis`` are not part of it).
    """
    from coordarm.generated.code_identity import sources_digest
    return sources_digest(Path(__file__).resolve().parent.parent, ("symbolic", "simulation"))


def build_info(scenario: Scenario) -> dict[str, str]:
    """The ``build`` metadata: code and scenario hashes and the versions that made the run.

    Parameters
    ----------
    scenario : Scenario
        The scenario of the run (hashed as its JSON).

    Returns
    -------
    dict of str to str
        ``code_hash``, ``scenario_hash`` and the versions of coordarm, casadi, numpy, mcap,
        zstandard, lz4 and python (``"unknown"`` for a package that is not installed).
    """
    import casadi
    return {"code_hash": code_hash(), "scenario_hash": sha256(scenario.to_json().encode()).hexdigest(),
            "coordarm": installed_version("coordarm.version"), "casadi": casadi.__version__, "numpy": np.__version__,
            **{name: installed_version(name) for name in ("mcap", "zstandard", "lz4")},
            "python": platform.python_version()}


class RunLogger:
    """Writes one run to an MCAP file; pass :meth:`on_chunk` to :func:`simulation.run.simulate`.

    Use as a context manager: leaving the block (normally, by a singularity, an exception or
    Ctrl-C) writes the ``outcome`` and closes the file.

    Parameters
    ----------
    path : str or Path
        The log file to create; it is written as :func:`partial_path` and renamed at the end.
    scenario : Scenario
        The scenario being run (stored whole in the ``scenario`` metadata).
    ctrl : CoordinatingController, optional
        Its controller (default: ``scenario.controller()``), for the scene and ``cond``.
    log_rate : float, optional
        Samples per simulated second on the per-step channels (default: every step).
    scene_rate : float
        Rate of ``/scene``, ``/tf`` and ``/tracking`` [Hz]; 0 switches them off.
    cond_rate : float, optional
        Rate of ``/margins/cond`` [Hz]; 0 switches it off. Default :func:`default_cond_rate`:
        1 Hz up to 256 links and 0.5 Hz above for the 1-norm value; for the exact 2-norm value 1 Hz up
        to 64 links, then falling as ``1/m^2``
        (an SVD costs O(m^3), a step O(m)); 0 for a spatial chain (the ``run`` metadata's
        ``chain_kind`` is ``"universal"``).
    cond_exact : bool
        Log the exact 2-norm condition number (an SVD per sample) instead of the O(m) 1-norm
        estimate; a spatial chain always logs the exact value (when a rate is given).
    compression : {"lz4", "zstd", "none"}
        Chunk compression, default :data:`~.choices.DEFAULT_COMPRESSION` (lz4; see :class:`~simulation.mcap_file.McapFile`).
    chunk_size : int, optional
        Target uncompressed chunk size [bytes] (default :data:`CHUNK_SIZE`, 1 MiB).
    flush_interval : float
        Wall time between pushes of the written chunks to the operating system [s].
    overwrite : bool
        Replace an existing file at ``path`` (else a LogError before anything is written).
    command : list of str, optional
        Command line stored in the ``run`` metadata (default: ``sys.argv``).
    backend : str
        Simulation backend, stored in the ``build`` metadata (written with the first block, so
        :meth:`set_backend` may still change it).
    library_key : str, optional
        Cache key (SHA-256 of the generated code and its build) of the compiled library that
        ran, stored in the ``build`` metadata.
    threaded : bool
        Encode on a worker thread and compress on another (blocks are queued by :meth:`on_chunk`),
        overlapping the log with a compiled simulation when a second core is free: on 2 cores
        full-rate logging then costs 1.7x the unlogged run instead of 2.5x
        (benchmarks/RESULTS_logging.md). ``coordarm run`` uses it on machines with 2+ cores.
    frames : {"ends", "all"}
        The frames of ``/tf``: ``base`` and ``tip`` (default), or one per link (:mod:`.scene`).
    free_replaced_later : bool
        When the log replaces a file, free that file's storage on a background thread (20-30 ms for a
        40 MB log on ext4) rather than before :meth:`finish` returns; :func:`.file_replace.wait_released`
        waits for it (``coordarm run`` does, once the summary is out). The rename is atomic either way.

    Raises
    ------
    ConfigError
        A rate that is not a positive number.
    LogError
        The file cannot be created, exists (``overwrite=False``) or another run is writing it.
    """

    def __init__(self, path: str | Path, scenario: Scenario, ctrl: CoordinatingController | None = None, *,
                 log_rate: float | None = None, scene_rate: float = SCENE_RATE, cond_rate: float | None = None,
                 compression: str = DEFAULT_COMPRESSION, chunk_size: int | None = None, flush_interval: float = FLUSH_INTERVAL,
                 command: list[str] | None = None, backend: str = Backend.INTERPRETED.value, library_key: str | None = None,
                 threaded: bool = False, overwrite: bool = True, cond_exact: bool = False,
                 frames: str = "ends", free_replaced_later: bool = False) -> None:
        self.frames = frames
        self.free_replaced_later = free_replaced_later
        ctrl = ctrl or scenario.controller()     # (may take a while: not with Ctrl-C held back)
        with self._removed_on_failure():
            self.cond_exact = bool(cond_exact)
            with _sigint_deferred():   # a Ctrl-C while the file and its metadata are made comes after them
                self._open(path, scenario, ctrl, log_rate, scene_rate, cond_rate, compression, flush_interval,
                           overwrite, threaded)
                self._write_header(command, backend, library_key)
            self._prepare_buffers(chunk_size, threaded)

    @contextmanager
    def _removed_on_failure(self):
        """A failure before the writer is complete leaves no half-made file; a Ctrl-C or SIGTERM once the
        file exists leaves a closed log of no samples with outcome ``interrupted``."""
        try:
            yield
        except BaseException as exc:
            file = getattr(self, "file", None)
            if file is not None and not (interruption(exc) is not None and self._closed_empty(exc)):
                file.abandon()
                file.path.unlink(missing_ok=True)
            raise

    def _closed_empty(self, error: BaseException) -> bool:
        """Close the log begun in ``__init__`` with its scenario and the outcome of ``error``; whether it worked."""
        try:
            with _sigint_deferred():
                if self.file.closed:
                    return False
                if not getattr(self, "_scenario_written", False):
                    self.file.add_metadata("scenario", {"json": self.scenario.to_json(), "source": self.scenario.source})
                if not getattr(self, "_build_written", False) and getattr(self, "_build", None):
                    self.file.add_metadata("build", self._build)
                self.file.add_metadata("outcome", {k: json.dumps(v) for k, v in outcome_of(error, None).items()})
                self.file.close(rename_to=self.path, free_replaced_later=self.free_replaced_later)
                return True
        except Exception:   # noqa: BLE001 - then the half-made file is removed as before
            return False

    def _open(self, path, scenario, ctrl, log_rate, scene_rate, cond_rate, compression, flush_interval,
              overwrite, threaded) -> None:
        """Check the rates and compression, create the file and its channels."""
        self.ctrl = ctrl or scenario.controller()
        self.layout = layout_of_chain(self.ctrl.chain)
        if self.layout is PLANAR and not is_built_in(self.ctrl.curve) and scenario.curve is not self.ctrl.curve:
            scenario = scenario.with_curve(self.ctrl.curve)      # the log records a user-defined curve
        self.scenario = scenario
        self.step = scenario.step
        self.every = self._decimation(log_rate, "log_rate") if log_rate is not None else 1
        m = self.ctrl.chain.m
        cond_rate, self.cond_exact = cond_plan(self.ctrl, cond_rate, self.cond_exact, self.layout is PLANAR)
        self.scene_every = self._decimation(scene_rate, "scene_rate") if scene_rate else 0
        self.cond_every = self._decimation(cond_rate, "cond_rate") if cond_rate else 0
        if compression not in COMPRESSIONS:
            raise ConfigError(f"compression: expected one of {COMPRESSIONS}, got {compression!r}")
        self.flush_interval = float(flush_interval)
        self.path = Path(path)
        self.channels: dict[str, NumericChannel] = numeric_channels(m, self.ctrl.chain.rail, self.layout)
        if not overwrite and self.path.exists():
            raise LogError(f"{self.path}: exists; choose another --out or pass --overwrite")
        try:
            self.file = McapFile(partial_path(self.path), profile="ros2", compression=compression,
                                 background=threaded)
        except OSError as exc:
            raise LogError(f"{self.path}: cannot create the log: {exc.strerror or exc}") from None
        self.ids: dict[str, int] = {}
        for key, ch in self.channels.items():
            if key == "tracking" and not self.scene_every:
                continue
            sid = self.file.add_schema(ch.schema_name, "ros2msg", ch.schema_text().encode())
            self.ids[key] = self.file.add_channel(ch.topic, "cdr", sid)
        if self.scene_every:
            sids: dict[str, int] = {}       # /scene and /scene/fixed share their schema
            for key, (topic, schema) in FOXGLOVE_CHANNELS.items():
                if schema not in sids:
                    sids[schema] = self.file.add_schema(schema, "jsonschema", foxglove_schema_bytes(schema))
                self.ids[key] = self.file.add_channel(topic, "json", sids[schema])

    def _write_header(self, command: list[str] | None, backend: str, library_key: str | None) -> None:
        """Write the ``scenario`` and ``run`` metadata (``build`` follows with the first block)."""
        scenario = self.scenario
        self.origin = min(0.0, scenario.t0)  # log times are ns since this simulated time (>= 0)
        self.file.add_metadata("scenario", {"json": scenario.to_json(), "source": scenario.source})
        self._scenario_written = True
        self._build: dict[str, str] | None = None
        self._build_info: dict[str, str] | None = None   # build_info(scenario), the same for every backend
        self._build_written = False
        self._lock = threading.RLock()  # the worker's idle flush against flush() from the caller
        self.file.add_metadata("run", {
            "command": json.dumps(list(sys.argv if command is None else command)),
            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"), "host": host_name(),
            "platform": host_platform(), "log_every_steps": str(self.every),
            "scene_every_steps": str(self.scene_every), "cond_every_steps": str(self.cond_every),
            "cond": COND_KINDS[self.cond_exact],
            "time_origin": repr(self.origin),
            **({} if self.layout is PLANAR else {"chain_kind": self.layout.kind})})
        self.file.flush()        # scenario and run on disk at once (a SIGKILL from here on keeps them)
        self.set_backend(backend, library_key)

    def _prepare_buffers(self, chunk_size: int | None, threaded: bool) -> None:
        """The packed sample records, the pending queues and (``threaded``) the encoding worker."""
        # One sample = one message on each per-step channel, laid out as a packed record.
        layout = []
        for key in PER_STEP:
            ch = self.channels[key]
            layout += [(key + "_hdr", MESSAGE_HEADER_DTYPE), (key + "_cdr", "V4"), (key, "<f8", (ch.width,))]
        self.sample_dtype = np.dtype(layout)
        self.samples_per_chunk = max(1, (chunk_size or CHUNK_SIZE) // self.sample_dtype.itemsize)
        self._pending = np.empty(0, self.sample_dtype)
        self._arrays = RecycledArrays(self.sample_dtype, self._constant_fields)   # the blocks' records
        self._packer = RecordPacker(self.sample_dtype, self.channels, PER_STEP)
        self._extras: list[tuple[str, int, bytes]] = []  # (channel key, log time, data) at reduced rates
        self._sequence = {key: 0 for key in self.ids}
        self._seen = 0          # steps received so far (the global index of the next one)
        self._last: Run | None = None
        self._last_logged = -1  # global index of the last sample logged
        self._governed = 0.0    # simulated time with v_scale < 1 [s]
        self._flushed = self._received = time.monotonic()
        self._gap = 0.0  # wall time between the last two blocks
        self.scene = scene_builder(self.ctrl, self.scenario.obstacles,
                                   getattr(self.scenario.physical(self.ctrl.chain), "radius", None), self.frames)
        self.scene.views = True       # the scenes' JSON is copied into the chunks' records: no copy before
        self.outcome: dict[str, Any] | None = None
        #: Contact records of an ``--allow-contact`` run, written into the outcome (set by the caller).
        self.contacts: list[dict] = []
        #: The run's peak joint accelerations (``run.info["joint_rates"]``, set by the caller; a stopped
        #: run's come with its error), written into the outcome as ``joint_rates``.
        self.joint_rates: dict | None = None
        # At most two blocks wait (so a kill loses at most ~1 s, and the queue holds at most two
        # blocks: the run itself keeps only thinned rows); an idle worker still pushes the last
        # block out in time.
        self._worker = Worker(self._process, "coordarm-log", 2, idle=self._flush_if_due,
                              idle_interval=self.flush_interval / 2) if threaded else None

    @property
    def writing(self) -> Path:
        """The file being written (:func:`partial_path` until closed, then :attr:`path`)."""
        return self.file.path

    def set_backend(self, backend: str, library_key: str | None = None) -> None:
        """Record the simulation backend (and compiled library) in the ``build`` metadata.

        Parameters
        ----------
        backend : str
            ``"compiled"`` or ``"interpreted"``.
        library_key : str, optional
            Cache key of the compiled library.

        Raises
        ------
        LogError
            Called after the first block was logged.
        """
        if self._build_written:
            raise LogError(f"{self.path}: the backend is recorded before the first block")
        if self._build_info is None:
            self._build_info = build_info(self.scenario)
        self._build = {**self._build_info, "backend": backend}
        if library_key:
            self._build["library_key"] = library_key

    def _write_build(self) -> None:
        if not self._build_written:
            self.file.add_metadata("build", self._build)
            self._build_written = True

    def _check(self) -> None:
        if self._worker is not None and self._worker.error is not None:
            raise self._failure(self._worker.error)

    def _failure(self, error: BaseException) -> LogError:
        return LogError(f"{self.path}: writing the log failed: {type(error).__name__}: {error}")

    def _decimation(self, rate: Any, name: str) -> int:
        return steps_between(rate, self.step, name)

    # ---------------------------------------------------------------- writing
    def on_chunk(self, part: Run) -> None:
        """Log a block of consecutive steps (a :class:`Run` of their rows; its arrays must not change later).

        Parameters
        ----------
        part : Run
            The block's rows, following the previous block's.

        Raises
        ------
        LogError
            Writing an earlier block failed (e.g. the disk is full).
        """
        self._check()
        self._write_build()
        now = time.monotonic()
        self._gap, self._received = now - self._received, now
        if self._worker is not None:
            self._worker.put(part)
        else:
            with _sigint_deferred():  # Ctrl-C half-way through a block would leave a gap in the log
                self._process(part)

    def _process(self, part: Run) -> None:
        with self._lock:
            self._process_locked(part)

    def _process_locked(self, part: Run) -> None:
        n = len(part.t)
        g = self._seen + np.arange(n)
        self._seen += n
        self._governed += self.step * governed_steps(part)   # each step lasts self.step (as Run.governed_time)
        self._last = part
        rows = np.flatnonzero(g % self.every == 0)
        if len(rows):
            self._add_samples(part, rows)
            self._last_logged = int(g[rows[-1]])
        if self.scene_every:
            self.scene.advance(part)
            ks = np.flatnonzero(g % self.scene_every == 0)
            self._extras += self.scene.messages(part, ks, self._ns(part.t[ks]))
        if self.cond_every:
            ks = np.flatnonzero(g % self.cond_every == 0)
            if len(ks):
                for k, value in zip(ks, cond_values(self.ctrl, self.cond_exact, part.q[ks], part.t[ks])):
                    record = CDR_HEADER + np.array([part.t[k], value], "<f8").tobytes()
                    self._extras.append(("cond", int(self._ns(part.t[k])), record))
        while len(self._pending) >= self.samples_per_chunk:
            self._write_chunk(self.samples_per_chunk)
        # Without a worker nothing runs until the next block: flush now if that would come too late.
        wait = 0.0 if self._worker is not None else self._gap
        if time.monotonic() - self._flushed + wait >= self.flush_interval:
            self._flush_now()

    def _flush_if_due(self) -> None:
        """Flush from the idle worker when blocks arrive slowly (see :class:`Worker`)."""
        with self._lock:
            if (len(self._pending) or self._extras) and time.monotonic() - self._flushed >= self.flush_interval / 2:
                self._flush_now()

    def _ns(self, t: float | np.ndarray):
        return log_time_ns(t, self.origin)

    def _add_samples(self, part: Run, rows: np.ndarray) -> None:
        n, held = len(rows), len(self._pending)
        if n and rows[-1] - rows[0] == n - 1:
            rows = slice(int(rows[0]), int(rows[-1]) + 1)   # every step: no gathered copies
        whole = self._arrays.take(held + n, self.samples_per_chunk)   # the samples not yet in a chunk, then these
        whole[:held] = self._pending
        # (opcode, length, channel and CDR header: _constant_fields)
        self._packer.pack(whole[held:], part, rows, [self._sequence[key] for key in PER_STEP], self._ns(part.t[rows]))
        for key in PER_STEP:
            self._sequence[key] += n
        self._pending = whole

    def _constant_fields(self, records: np.ndarray) -> None:
        """Write the fields that every sample record has alike (a new array's, once: the arrays are recycled)."""
        for key in PER_STEP:
            hdr, size = records[key + "_hdr"], MESSAGE_HEADER_SIZE - 9 + self.channels[key].size
            hdr["opcode"], hdr["length"], hdr["channel"] = 0x05, size, self.ids[key]
            records[key + "_cdr"] = np.frombuffer(CDR_HEADER, "V4")[0]

    def _write_chunk(self, n: int) -> None:
        block, self._pending = self._pending[:n], self._pending[n:]
        size, index = self.sample_dtype.itemsize, {}
        base = np.arange(n, dtype=np.uint64) * np.uint64(size)
        for key in PER_STEP:
            if n:
                offset = np.uint64(self.sample_dtype.fields[key + "_hdr"][1])
                index[self.ids[key]] = (block[key + "_hdr"]["log_time"], base + offset)
        if n and len(self._pending):  # more samples follow: keep their scene/cond for the next chunk
            end = int(block[PER_STEP[0] + "_hdr"]["log_time"][-1])
            extras = [x for x in self._extras if x[1] <= end]
            self._extras = [x for x in self._extras if x[1] > end]
        else:
            extras, self._extras = self._extras, []
        parts = [block.view(np.uint8)]       # (a view: the block is never written again)
        if extras:
            keys = [key for key, _, _ in extras]
            sequences = [self._next_sequence(key) for key in keys]
            channels = np.array([self.ids[key] for key in keys])
            log_times = np.array([lt for _, lt, _ in extras], np.uint64)
            records, offsets = message_records(channels, sequences, log_times, [d for _, _, d in extras], n * size)
            parts.append(records)
            for cid in dict.fromkeys(channels.tolist()):   # in the order of their first message
                new = log_times[channels == cid], offsets[channels == cid]
                if cid in index:
                    new = np.concatenate([index[cid][0], new[0]]), np.concatenate([index[cid][1], new[1]])
                index[cid] = new
        self.file.write_chunk(parts, index)

    def _next_sequence(self, key: str) -> int:
        """The sequence number of the next message of channel ``key`` (counting it)."""
        self._sequence[key] += 1
        return (self._sequence[key] - 1) & 0xFFFFFFFF

    def flush(self) -> None:
        """Wait for the queued blocks, write them as a chunk, push the file to the operating system."""
        if self._worker is not None:
            self._worker.join()
        self._check()
        with self._lock:
            self._flush_now()

    def _flush_now(self) -> None:
        if len(self._pending) or self._extras:
            self._write_chunk(len(self._pending))
        self.file.flush()
        self._flushed = time.monotonic()

    # ---------------------------------------------------------------- closing
    def finish(self, error: BaseException | None = None) -> None:
        """Log the last step if decimation skipped it, write ``outcome``, close the file.

        Does nothing when the file is closed already.

        Parameters
        ----------
        error : BaseException, optional
            Why the run ended (None: it completed); recorded by :func:`outcome_of`.

        Raises
        ------
        LogError
            Writing the log failed, now or on the worker thread (the partial file is abandoned).
        """
        if self.file.closed:
            return
        with _sigint_deferred():   # a Ctrl-C now is delivered once the log is closed (never a .partial left)
            self._finish(error)

    def _finish(self, error: BaseException | None) -> None:
        worker, self._worker = self._worker, None
        if worker is not None:
            worker.stop()
            if worker.error is not None:
                self.file.abandon()
                raise self._failure(worker.error)
        try:
            last_t = None
            if self._last is not None:
                last_t = float(self._last.t[-1])
                if self._last_logged != self._seen - 1:
                    self._add_samples(self._last, np.array([len(self._last.t) - 1]))
            if len(self._pending) or self._extras:
                self._write_chunk(len(self._pending))
            self._write_build()
            self.outcome = outcome_of(error, last_t, self.contacts, self._governed)
            peaks = self.joint_rates or getattr(getattr(error, "run", None), "info", {}).get("joint_rates")
            if peaks:
                self.outcome["joint_rates"] = dict(peaks)
            self.file.add_metadata("outcome", {k: json.dumps(v) for k, v in self.outcome.items()})
            self.file.close(rename_to=self.path, free_replaced_later=self.free_replaced_later)
        except Exception as exc:
            self.file.abandon()
            raise LogError(f"{self.path}: writing the log failed: {type(exc).__name__}: {exc}") from exc
        except BaseException:
            self.file.abandon()
            raise

    def __enter__(self) -> "RunLogger":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        self.finish(exc)
        return False


@contextmanager
def _sigint_deferred():
    """Hold back SIGINT (Ctrl-C), and SIGTERM when Python handles it, until the block ends; then
    deliver the first one caught to its previous handler."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[tuple[int, Any]] = []
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signum == signal.SIGINT or callable(signal.getsignal(signum)):
            previous[signum] = signal.signal(signum, lambda n, frame: caught.append((n, frame)))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if caught and callable(previous[caught[0][0]]):
            previous[caught[0][0]](*caught[0])
