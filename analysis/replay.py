"""Read a run log back: :func:`load` returns the arrays, the scenario and how the run ended.

Only the file is needed: the scenario is rebuilt from the ``scenario`` metadata, so
``replay.scenario.controller()`` is the controller that made the run.

The file is read as a stream of records (not through its summary section), so that a log
whose writer was killed, which lacks its end, is read up to its last complete chunk; such a
log comes back with ``recovered = True``. Damage is survived: a chunk whose CRC or
compressed data is bad is skipped and named in ``problems`` (``damaged = True``), and the
rest loads. The metadata records carry a SHA-256 of their entries: a mismatch raises a
:class:`~symbolic.errors.LogError` naming the record, as do a file that is not MCAP, is
empty, or lacks the scenario. A closed log without samples (a run interrupted before its
first step) loads as an empty run.
"""
from __future__ import annotations

import io
import json
import struct
import zlib
from collections import namedtuple
from dataclasses import dataclass, field, fields
from typing import Any
from pathlib import Path

import numpy as np
import zstandard

from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, DataEnd, Footer, Metadata, Schema
from mcap.data_stream import ReadDataStream
from mcap.stream_reader import CRCValidationError

from coordarm.simulation.choices import Backend, Compression, Outcome, lz4_frame
from coordarm.simulation.mcap_file import MCAP0_MAGIC as MCAP_MAGIC
from coordarm.simulation.log_schemas import CDR_HEADER, PER_STEP, NumericChannel, fields_from_schema, numeric_channels
from coordarm.simulation.log_layout import (DIGEST_KEY, OPTIONAL, PLANAR, ChainLayout, layout_of, layout_of_arrays,
                                           metadata_digest, partial_path)
from coordarm.simulation.result import ExtraOutputs, Run
from coordarm.simulation.scenario import USER_DEFINED, Scenario
from coordarm.symbolic import ConfigError, CoordinatingController, LogError
from coordarm.symbolic.errors import shown

#: Exceptions the mcap reader raises on damaged input (it has no single base class for them).
READ_ERRORS = (McapError, CRCValidationError, zstandard.ZstdError, struct.error, zlib.error, EOFError,
               UnicodeDecodeError, ValueError, KeyError, IndexError, MemoryError)


#: A message as read here: much lighter than ``mcap.records.Message`` (a log has ~10^5 of them).
RawMessage = namedtuple("RawMessage", "channel_id sequence log_time data")
RawMessage.__doc__ = """One MCAP message record as read from a chunk.

Parameters
----------
channel_id : int
    The channel's id.
sequence : int
    Sequence number.
log_time : int
    Log time [ns].
data : memoryview
    The message body (a view into the decompressed chunk).
"""
_RECORD = struct.Struct("<BQ")
_MESSAGE = struct.Struct("<HIQ")


def chunk_messages(chunk: Chunk) -> list[RawMessage]:
    """The messages of a chunk, its CRC checked (other records inside a chunk are skipped).

    Parameters
    ----------
    chunk : mcap.records.Chunk
        A chunk record (zstd, lz4 or uncompressed).

    Returns
    -------
    list of RawMessage
        Its messages in file order.

    Raises
    ------
    CRCValidationError, zstandard.ZstdError, struct.error, ValueError
        Damaged chunk (the caller turns these into a LogError).
    """
    if chunk.compression == Compression.ZSTD:
        data = zstandard.decompress(chunk.data, chunk.uncompressed_size)
    elif chunk.compression == Compression.LZ4:
        try:
            data = lz4_frame().decompress(chunk.data)
        except RuntimeError as exc:  # what python-lz4 raises on a damaged frame
            raise ValueError(f"lz4: {exc}") from None
    elif chunk.compression == "":
        data = chunk.data
    else:
        raise ValueError(f"unsupported chunk compression {chunk.compression!r}")
    if len(data) != chunk.uncompressed_size:
        raise ValueError(f"chunk holds {len(data)} bytes, its header says {chunk.uncompressed_size}")
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise CRCValidationError(chunk.uncompressed_crc, zlib.crc32(data), chunk)
    out, pos, end, view = [], 0, len(data), memoryview(data)
    while pos < end:
        opcode, length = _RECORD.unpack_from(data, pos)
        body = pos + 9
        if body + length > end:
            raise ValueError(f"record of {length} bytes runs past the end of its chunk")
        if opcode == Opcode.MESSAGE:
            cid, seq, log_time = _MESSAGE.unpack_from(data, body)
            out.append(RawMessage(cid, seq, log_time, view[body + 22:body + length]))
        pos = body + length
    return out


@dataclass
class Replay(ExtraOutputs):
    """A run read back from its log; rows are samples in time order.

    Attributes
    ----------
    path : Path
        The log file.
    t, s, v_star, longitudinal : (N,) arrays
        Time [s], arc length of the end point [m], commanded speed [m/s], longitudinal margin
        (None for a spatial chain).
    q, u : (N, m) arrays
        Joint coordinates [rad] and control (N, m+1 on a rail: ``d`` [m] and its rate first; N, 2m
        for a spatial chain: ``(a_1, b_1, ...)``).
    e, link_margins : (N, m-1) arrays
        Deviations ``e^2..e^m`` [m] (N, 2(m-1) for a spatial chain: ``e^2_1, e^2_2, e^3_1, ...``) and
        link margins of links 2..m.
    cond_t, cond : (K,) arrays
        Times and values of the decoupling matrix condition number (reduced rate).
    scenario : Scenario
        The scenario rebuilt from the log.
    scenario_dict : dict
        The scenario as stored (JSON).
    build, run_info : dict
        The ``build`` and ``run`` metadata.
    outcome : dict
        How the run ended (``status``: completed, singularity, error, interrupted), or
        ``{"status": "unknown"}`` if the writer never finished (killed).
    recovered : bool
        True if the file lacks its end (a killed or truncated run) and was read up to the break.
    damaged : bool
        True if damaged data was skipped (chunks with a bad CRC, or reading stopped early).
    messages : int
        Messages read.
    problems : list of str
        What was dropped while reading (incomplete trailing samples, a damaged tail).
    extra : dict
        Logged law outputs that are not fields above (see :attr:`coordarm.simulation.run.Run.extra`;
        for a spatial chain ``roll``, ``roll_star``, ``end_margin``, ``joint_margins``).
    """

    path: Path
    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    e: np.ndarray
    s: np.ndarray
    v_star: np.ndarray
    link_margins: np.ndarray
    longitudinal: np.ndarray | None
    cond_t: np.ndarray
    cond: np.ndarray
    scenario: Scenario
    scenario_dict: dict
    build: dict
    run_info: dict
    outcome: dict
    recovered: bool
    messages: int
    problems: list = field(default_factory=list)
    extra: dict = field(default_factory=dict)
    damaged: bool = False

    def condition(self) -> str | None:
        """Say whether the log was cut off or damaged, and what was kept.

        Returns
        -------
        str or None
            One line, e.g. ``"the log is damaged: 1200 samples kept (up to t = 1.199 s)"``, or
            None for an intact log.
        """
        what = [w for w, flag in (("cut off (the run was killed?)", self.recovered),
                                  ("damaged", self.damaged)) if flag]
        if not what:
            return None
        span = f"up to t = {self.t[-1]:.3f} s" if len(self.t) else "no samples"
        return f"the log is {' and '.join(what)}: {len(self.t)} samples kept ({span})"

    def to_run(self) -> Run:
        """The samples as a :class:`coordarm.simulation.run.Run` (for the figure functions).

        Returns
        -------
        Run
            The samples (``t``, ``q``, ``u`` and the rest), with ``info`` holding the backend,
            the outcome's status as ``stopped``, its contacts and its ``joint_rates`` (the peaks).
        """
        keys = self.layout.arrays + tuple(a for a in OPTIONAL if a in self.extra)
        return Run.from_arrays({a: getattr(self, a) for a in keys},
                               info={"backend": self.build.get("backend", "?"), "stopped": self.outcome.get("status", "?"),
                                     "contacts": self.outcome.get("contacts", []),
                                     "joint_rates": self.outcome.get("joint_rates")})

    @property
    def layout(self) -> ChainLayout:
        """The layout of the logged arrays (planar or spatial, :mod:`coordarm.simulation.log_layout`)."""
        return layout_of_arrays({f.name for f in fields(self)} | set(self.extra))

    def controller(self) -> CoordinatingController:
        """The controller that made the run, rebuilt from the scenario.

        Returns
        -------
        CoordinatingController
            A new controller from :attr:`scenario` (not cached).
        """
        return self.scenario.controller()


def _read_records(path: Path):
    """Schemas, channels, messages, metadata; whether the end was reached; the error that stopped reading.

    The records are read in file order, chunk CRCs checked; message indexes and the summary
    are skipped (a killed run has none). A file that ends with the MCAP magic was closed by its
    writer: a read error in it is damage.
    """
    schemas, channels, messages, meta = {}, {}, [], {}
    complete, error, skipped = False, None, []
    readers = {Opcode.SCHEMA: Schema.read, Opcode.CHANNEL: Channel.read, Opcode.METADATA: Metadata.read,
               Opcode.CHUNK: Chunk.read, Opcode.DATA_END: DataEnd.read, Opcode.FOOTER: Footer.read}
    with open(path, "rb") as f:
        head = f.read(len(MCAP_MAGIC))
        if head != MCAP_MAGIC:
            what = "an empty file" if not head else "not an MCAP file (no MCAP magic at its start)"
            raise LogError(f"{path}: {what}")
        size = path.stat().st_size
        try:
            while True:
                header = f.read(_RECORD.size)
                if len(header) < _RECORD.size:
                    raise EOFError(f"the file ends {'inside a record header' if header else 'without its footer'}")
                opcode, length = _RECORD.unpack(header)
                if length > size - f.tell():
                    raise EOFError(f"a record of {length} bytes runs past the end of the file")
                body = f.read(length)
                if opcode not in readers:
                    continue
                rec = readers[opcode](ReadDataStream(io.BytesIO(body)))
                if isinstance(rec, Chunk):
                    try:
                        messages += chunk_messages(rec)
                    except READ_ERRORS as exc:   # skip it, keep reading: the records are framed
                        skipped.append(f"chunk at byte {f.tell() - length - _RECORD.size} skipped "
                                       f"({type(exc).__name__}: {str(exc)[:80]})")
                elif isinstance(rec, Channel):
                    channels[rec.id] = rec
                elif isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Metadata):
                    meta[rec.name] = dict(rec.metadata)
                elif isinstance(rec, Footer):
                    complete = True
                    break
        except READ_ERRORS as exc:
            error = exc
            complete = False
        f.seek(max(0, size - len(MCAP_MAGIC)))
        has_end = size >= 2 * len(MCAP_MAGIC) and f.read() == MCAP_MAGIC
    complete = complete and has_end
    if error is not None and has_end:  # a closed file: not cut off but damaged; what follows is lost
        skipped.append(f"reading stopped at damaged data: {type(error).__name__}: {str(error)[:80]} "
                       f"({len(messages)} messages read before it)")
        complete, error = True, None
    return schemas, channels, messages, meta, complete, error, skipped


def _checked_metadata(meta: dict[str, dict], path: Path) -> None:
    """Verify each record's SHA-256 (logs written before it existed have none)."""
    for name, data in meta.items():
        if DIGEST_KEY in data and data[DIGEST_KEY] != metadata_digest(data):
            raise LogError(f"{path}: the '{name}' metadata record is damaged (its SHA-256 does not match)")


def _json_values(record: dict[str, str], name: str, path: Path) -> dict:
    try:
        return {k: json.loads(v) for k, v in record.items() if k != DIGEST_KEY}
    except (ValueError, RecursionError) as exc:
        raise LogError(f"{path}: the '{name}' metadata holds a value that is not JSON: {str(exc)[:80]}") from None


def _decode(channel_messages: list[RawMessage], width: int, topic: str, path: Path) -> np.ndarray:
    size = len(CDR_HEADER) + 8 * width
    wrong = [len(m.data) for m in channel_messages if len(m.data) != size]
    raw = b"".join(m.data for m in channel_messages)
    rec = np.frombuffer(raw, np.dtype([("h", "V4"), ("d", "<f8", (width,))])) if not wrong else None
    if wrong or not (rec["h"] == np.frombuffer(CDR_HEADER, "V4")[0]).all():
        got = f"a message of {wrong[0]} bytes" if wrong else "a message without the CDR little-endian header"
        raise LogError(f"{path}: {topic}: {got}; expected {size} bytes (CDR little-endian, {width} float64)")
    return rec["d"].reshape(len(channel_messages), width).copy()


def load(path: str | Path, curve: Any = None) -> Replay:
    """Read the log at ``path`` (or, if it is missing, its unfinished :func:`partial_path`).

    Parameters
    ----------
    path : str or Path
        An MCAP log written by ``coordarm run`` (also one cut short by a killed run).
    curve : Curve, optional
        The user-defined :class:`~coordarm.symbolic.Curve` the run used, needed (and only
        used) when the log records ``[curve] kind = "user-defined"``.

    Returns
    -------
    Replay
        The samples, the scenario and the metadata of the log.

    Raises
    ------
    LogError
        Missing, empty, foreign or damaged file (naming it and how many messages were read
        before the damage), or a log without a usable scenario or any complete sample.
    """
    path, note = Path(path), []
    if not path.is_file() and partial_path(path).is_file():  # the run has not finished (or was killed)
        note = [f"{path} does not exist (yet): read the unfinished {partial_path(path).name}"]
        path = partial_path(path)
    if not path.is_file():
        raise LogError(f"{path}: no such log file")
    schemas, channels, messages, meta, complete, error, skipped = _read_records(path)
    _checked_metadata(meta, path)
    where = f"{path}: {'not a coordarm run log' if complete else 'MCAP log cut off'}"
    detail = f" ({type(error).__name__}: {error})" if error else ""
    if "scenario" not in meta:
        raise LogError(f"{where}: no 'scenario' metadata could be read ({len(messages)} messages recovered "
                       f"before the break){detail}")
    try:
        spec = json.loads(meta["scenario"]["json"])
        if not isinstance(spec, dict):
            raise TypeError(f"a JSON {type(spec).__name__}, not a table")
        scenario = Scenario.from_dict(spec, f"{path} (scenario metadata)",
                                      curve=curve if spec.get("curve", {}).get("kind") == USER_DEFINED else None)
    except (KeyError, TypeError, ValueError, RecursionError, ConfigError) as exc:
        raise LogError(f"{path}: the 'scenario' metadata is not a valid scenario: {exc}") from None
    m = scenario.config.chain.links
    rail = scenario.chain().rail
    try:
        layout = layout_of(meta.get("run", {}).get("chain_kind"))
    except KeyError as exc:
        raise LogError(f"{path}: the 'run' metadata names {exc.args[0]}") from None
    specs = _channels(m, rail, layout)
    by_topic = {ch.topic: cid for cid, ch in channels.items()}
    per_channel: dict[str, np.ndarray] = {}
    grouped: dict[int, list[RawMessage]] = {}
    for msg in messages:
        grouped.setdefault(msg.channel_id, []).append(msg)
    for key, ch in specs.items():
        cid = by_topic.get(ch.topic)
        stored = schemas.get(channels[cid].schema_id) if cid is not None else None
        if stored is not None and stored.encoding == "ros2msg":   # the file's own layout (older logs differ)
            try:
                ch = specs[key] = NumericChannel(ch.topic, ch.schema_name, fields_from_schema(stored.data.decode()))
            except (ValueError, UnicodeDecodeError) as exc:
                raise LogError(f"{path}: {ch.topic}: unreadable schema: {exc}") from None
        msgs = grouped.get(cid, []) if cid is not None else []
        data = _decode(msgs, ch.width, ch.topic, path) if msgs else np.empty((0, ch.width))
        order = np.argsort(data[:, 0], kind="stable")
        per_channel[key] = data[order]
    problems = note + skipped
    for key in PER_STEP:  # publisher sequence numbers run 0, 1, 2, ... on every per-step channel
        cid = by_topic.get(specs[key].topic)
        seq = np.unique([msg.sequence for msg in grouped.get(cid, [])])
        missing = int(seq[-1] - seq[0] + 1 - len(seq)) if len(seq) else 0
        if missing:
            problems.append(f"{specs[key].topic}: {missing} message(s) missing (sequence gaps)")
    # A sample is complete when every per-step channel has it; keep those times only.
    times = [per_channel[k][:, 0] for k in PER_STEP]
    common = times[0]
    for tk in times[1:]:
        common = np.intersect1d(common, tk)
    dropped = max(len(tk) for tk in times) - len(common)
    if dropped:
        problems.append(f"{dropped} incomplete sample(s) dropped")
    if error is not None:
        problems.append(f"reading stopped at damaged data: {type(error).__name__}: {error}")
    if not complete and not messages:   # cut off (killed) before its first sample: an empty run, said so
        problems.append("the log was cut off before its first sample")
    if len(common) == 0 and messages:   # a log without samples (closed or cut off) is an empty run
        raise LogError(f"{where}: no complete sample could be read ({len(messages)} messages recovered before "
                       f"the break){detail}")
    cols = {}
    for key in PER_STEP:
        data = per_channel[key]
        _, first = np.unique(data[:, 0], return_index=True)
        data = data[first]
        data = data[np.isin(data[:, 0], common)]
        for name, sl in specs[key].slices().items():
            cols.setdefault(name, data[:, sl])
    dof = scenario.chain().dof
    if cols["q"].shape[1] != dof:
        raise LogError(f"{path}: the samples hold {cols['q'].shape[1]} joint values but the 'scenario' metadata "
                       f"describes {m} links ({dof} joints): the metadata do not belong to these data")
    problems += metadata_problems(meta, complete)
    current = _channels(m, rail, layout)
    for key in PER_STEP:      # fields added after the log was written: NaN, said in problems
        for name, n in current[key].fields:
            if name not in cols:
                cols[name] = np.full((len(common), n) if n else len(common), np.nan)
                problems.append(f"{current[key].topic}: no field {name!r} in this log (written before it "
                                "existed); filled with NaN")
    cond = per_channel["cond"]
    outcome = _json_values(meta["outcome"], "outcome", path) if "outcome" in meta else {"status": "unknown"}
    named = {f.name for f in fields(Replay)}
    given = {a: v for a, v in cols.items() if a in named}
    return Replay(path=path, **given, **{a: None for a in ("longitudinal",) if a not in given}, cond_t=cond[:, 0].copy(),
                  cond=cond[:, 1].copy(), scenario=scenario, scenario_dict=spec,
                  build=_strip(meta.get("build", {})), run_info=_strip(meta.get("run", {})), outcome=outcome,
                  recovered=not complete, messages=len(messages), problems=problems,
                  extra={a: v for a, v in cols.items() if a not in named}, damaged=bool(skipped))


def _channels(m: int, rail: bool, layout: ChainLayout) -> dict[str, NumericChannel]:
    """The numeric channels of a log of ``m`` links (on a ``rail``) of the chain kind ``layout``."""
    if layout is not PLANAR:
        return numeric_channels(m, rail, layout)
    return numeric_channels(m, True) if rail else numeric_channels(m)


def metadata_problems(meta: dict[str, dict], complete: bool) -> list[str]:
    """What is missing or unreadable in a log's ``run``, ``build`` and ``outcome`` metadata.

    Parameters
    ----------
    meta : dict
        The metadata records by name (string values).
    complete : bool
        The log was closed (then it must have an ``outcome``).

    Returns
    -------
    list of str
        One line per problem; empty when all three are there and readable.
    """
    problems = [f"no '{name}' metadata (damaged, or not written by coordarm run)"
                for name in ("run", "build") if name not in meta]
    if complete and "outcome" not in meta:
        problems.append("no 'outcome' metadata: how the run ended is unknown")
    if "outcome" in meta:
        status = meta["outcome"].get("status", "")
        known = {f'"{o.value}"' for o in Outcome}
        if status not in known:
            problems.append(f"the 'outcome' metadata names no known status ({shown(status)})")
    every = meta.get("run", {}).get("log_every_steps")
    if "run" in meta and not (every or "").isdigit():
        problems.append(f"the 'run' metadata has no step count between samples ({shown(every)})")
    backend = meta.get("build", {}).get("backend")
    if "build" in meta and backend not in {b.value for b in Backend}:
        problems.append(f"the 'build' metadata names no known backend ({shown(backend)})")
    return problems


def _strip(record: dict[str, str]) -> dict[str, str]:
    return {k: v for k, v in record.items() if k != DIGEST_KEY}
