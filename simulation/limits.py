"""Bounds on a run's inputs, what a run will cost, and the gain-step stability limits.

Hard bounds (a :class:`~symbolic.errors.ConfigError` whatever ``--yes`` says) keep every
number meaningful: log times are integer nanoseconds of simulated time, so steps shorter
than 1 us or times beyond 1e6 s would collide or overflow. The number of links has no
constant cap: :func:`estimate` gives the number of steps, the log size and the memory of a run
(the law's own data included, :data:`LAW_BYTES_PER_LINK`), :func:`check_cost` refuses a run above
:func:`cost_limits` (:data:`COST_LIMITS`, and half the machine's memory) unless the user confirmed
it (``coordarm run --yes``), and a run whose memory exceeds the machine's physical memory
(:func:`machine_memory`) is refused whatever ``--yes`` says.

Stability of the discretised loop: every deviation obeys ``edot = -K e``. RK4 with step
``h`` is stable for ``K h <`` :data:`RK4_LIMIT` (a larger ``K h`` diverges, whatever the
chain); a digital controller sampling every ``h`` with an ``n``-sample delay needs
``K h < 2 sin(pi / (2 (2 n + 1)))`` (:func:`sampled_limit`; :mod:`analysis.stability`
derives both).
"""
from __future__ import annotations

import math
import os
import warnings
from typing import Any

import numpy as np

from coordarm.symbolic import ConfigError
from coordarm.symbolic.checks import is_integer
from coordarm.symbolic.errors import shown
from coordarm.symbolic.records import record

from .choices import DENSE_LINKS  # noqa: F401 (re-exported)
from .log_layout import PLANAR, ChainLayout
from .log_schemas import PER_STEP, numeric_channels

#: Allowed RK4 step [s] (log times are integer ns; below 1 us consecutive times could collide).
STEP_RANGE = (1e-6, 1.0)
#: Longest simulated duration and largest ``|t0|`` [s] (keeps ns log times exact and in 64 bits).
MAX_TIME = 1e6
#: Allowed link length [m].
LINK_LENGTH_RANGE = (1e-6, 1e3)
#: Largest gain [1/s].
MAX_GAIN = 1e6
#: A run above any of these needs a confirmation (``--yes``): steps, log bytes, memory bytes (the memory
#: limit is raised to half the machine's memory by :func:`cost_limits`).
COST_LIMITS = {"steps": 20_000_000, "log_bytes": 4 * 2**30, "memory_bytes": 2 * 2**30}
#: Memory of the law per link while it is built, compiled and run [bytes] (a 16384-link line run of
#: 10 steps peaks at 250 MB; benchmarks/RESULTS.md, "Link counts").
LAW_BYTES_PER_LINK = 16 * 1024
#: Rows of a logged run kept in memory for the figures (the rest is streamed to the log).
KEEP_ROWS = 20_000   # (without figures: choices.SUMMARY_ROWS)


def _rk4_limit() -> float:
    """The real root of ``x^3 - 4 x^2 + 12 x - 24`` in (2.5, 3), correctly rounded to a float."""
    def cubic(x: float) -> tuple[int, int]:   # 24 (x^3/24 - x^2/6 + x/2 - 1) = n / d exactly (x = p / q, d > 0)
        p, q = x.as_integer_ratio()           # integers, not fractions.Fraction (3 ms to import at every start)
        return p**3 - 4 * p**2 * q + 12 * p * q**2 - 24 * q**3, q**3
    lo, hi = 2.5, 3.0
    while (mid := (lo + hi) / 2) not in (lo, hi):
        lo, hi = (mid, hi) if cubic(mid)[0] < 0 else (lo, mid)
    (n_lo, d_lo), (n_hi, d_hi) = cubic(lo), cubic(hi)
    return lo if abs(n_lo) * d_hi <= abs(n_hi) * d_lo else hi


#: ``K h`` limit of classical RK4 on ``edot = -K e``: the real root of ``|R(-x)| = 1`` in (2.5, 3),
#: ``R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24``; there ``R(-x) = 1``, i.e. ``x^3/24 - x^2/6 + x/2 - 1 = 0``.
#: Bisected on floats with the cubic's sign evaluated exactly, so the value is the root correctly
#: rounded (``np.roots`` was some ulp high, which moved the step of the RK4 divergence test).
RK4_LIMIT = _rk4_limit()


class GainStepWarning(UserWarning):
    """``K h`` is beyond what a digital controller sampling at the RK4 step could stabilise."""


def sampled_limit(delay: int = 0) -> float:
    """Limit of ``K h`` for the zero-order-hold loop with a ``delay``-sample delay: ``2 sin(pi/(2(2n+1)))``.

    Parameters
    ----------
    delay : int
        Control delay n >= 0 [samples].

    Returns
    -------
    float
        The largest stable ``K h`` [-] (gain [1/s] times sampling period [s]).

    Raises
    ------
    ConfigError
        ``delay`` is not an integer >= 0.
    """
    if not is_integer(delay, numpy=True) or delay < 0:
        raise ConfigError(f"delay: need an integer number of samples >= 0, got {delay!r}")
    return 2.0 * math.sin(math.pi / (2 * (2 * delay + 1)))


def check_gain_step(gain: float, step: float, refuse: bool = True, warn: bool = True) -> None:
    """Refuse (or, ``refuse=False``, warn about) a gain and step that RK4 cannot integrate stably;
    warn beyond the sampled-data limit.

    Parameters
    ----------
    gain : float
        Gain ``K`` [1/s].
    step : float
        RK4 step ``h`` [s].
    refuse : bool
        Raise (True) or warn (False) when RK4 diverges.
    warn : bool
        Warn beyond the sampled-data limit (else only the RK4 limit is checked).

    Raises
    ------
    ConfigError
        ``K h >= RK4_LIMIT`` and ``refuse``: the simulated deviations would grow without bound.

    Warns
    -----
    GainStepWarning
        ``K h >= 2``: a digital controller sampled at ``h`` would be unstable (or RK4 diverges).
    """
    kh = gain * step
    if not kh < RK4_LIMIT:
        text = (f"control.gain x run.step: K h = {gain:.4g} x {step:.4g} = {kh:.4g} >= {RK4_LIMIT:.4f}: "
                f"RK4 diverges; use a step below {RK4_LIMIT / gain:.3g} s or a smaller gain")
        if refuse:
            raise ConfigError(text)
        warnings.warn(text, GainStepWarning, stacklevel=3)
    elif warn and kh >= sampled_limit(0):
        warnings.warn(f"K h = {kh:.4g} >= 2: a digital controller sampling every {step:g} s would be unstable "
                      f"(K h < 2 sin(pi/(2(2n+1))) with an n-sample delay); the RK4 run is not", GainStepWarning,
                      stacklevel=3)


def check_links(links: int) -> None:
    """Refuse a link count whose law alone would not fit in this machine's memory (there is no fixed cap).

    Parameters
    ----------
    links : int
        ``chain.links``, number of links.

    Raises
    ------
    ConfigError
        ``links`` times :data:`LAW_BYTES_PER_LINK` is more than the machine's memory.
    """
    if links * LAW_BYTES_PER_LINK > (total := machine_memory()):
        raise ConfigError(f"chain.links: {shown(links)} links need at least {_size(links * LAW_BYTES_PER_LINK)} of "
                          f"memory, more than this machine's {_size(total)}")


def check_bounds(links: Any, link_length: float, step: float, duration: float, t0: float, gain: float) -> None:
    """Hard bounds on a scenario's numbers (see the module docstring); fields named as in the TOML.

    Parameters
    ----------
    links : int
        ``chain.links``, number of links.
    link_length : float
        ``chain.link_length`` [m].
    step : float
        ``run.step``, the integration step [s].
    duration : float
        ``run.duration`` [s].
    t0 : float
        ``run.t0``, start time [s] (its magnitude is bounded).
    gain : float
        ``control.gain``, error gain K [1/s].

    Raises
    ------
    ConfigError
        The first value outside its bound, or more links than the machine's memory holds.
    """
    check_links(links)
    checks = (("chain.link_length", link_length, *LINK_LENGTH_RANGE), ("run.step", step, *STEP_RANGE),
              ("run.duration", duration, 0.0, MAX_TIME), ("run.t0", abs(t0), 0.0, MAX_TIME),
              ("control.gain", gain, 0.0, MAX_GAIN))
    for name, value, lo, hi in checks:
        if not lo <= value <= hi:
            label = f"|{name}|" if name == "run.t0" else name
            raise ConfigError(f"{label}: need {lo:g} to {hi:g}, got {value:g}")


@record(frozen=True)
class Cost:
    """What a run will take (upper estimates).

    Attributes
    ----------
    steps : int
        RK4 steps.
    log_bytes : int
        Uncompressed size of the log's per-step channels (the file is smaller after compression).
    memory_bytes : int
        Arrays held in memory: the rows kept for the figures and one block being simulated.
    """

    steps: int
    log_bytes: int
    memory_bytes: int

    def describe(self) -> str:
        """The estimate in words, e.g. ``"1,000 steps, a log of up to 2.0 MiB, ..."``.

        Returns
        -------
        str
            Steps, log size and memory.
        """
        return (f"{self.steps:,} steps, a log of up to {_size(self.log_bytes)}, "
                f"{_size(self.memory_bytes)} of run data in memory")


def _size(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n} B"


def kept_every(keep: int | None, logged: bool, n_steps: int) -> int:
    """Keep every this many steps of a run in memory, to keep about ``keep`` rows.

    ``keep`` defaults to :data:`KEEP_ROWS` when the run is logged, else to every row.

    Parameters
    ----------
    keep : int or None
        Asked for by the caller.
    logged : bool
        The run streams every row to a log (``on_chunk`` given).
    n_steps : int
        Steps of the run.

    Returns
    -------
    int
        The stride, >= 1.
    """
    if keep is None:
        keep = KEEP_ROWS if logged else n_steps + 1
    return max(1, -(-n_steps // max(1, int(keep))))


def kept_capacity(n_steps: int, every: int, chunk: int, margins: int) -> int:
    """Rows a run keeps in memory at most (:class:`~.stepping.KeptRows` allocates them once).

    Every ``every``-th step and the final state; per chunk, beside them, the row of each margin's
    smallest value, of the largest ``|u|``, the summary's row (:func:`~.every_step.summary_rows`), the
    chunk's last row and one row of slack (the stride's phase at the chunk's start).

    Parameters
    ----------
    n_steps : int
        Steps of the run.
    every : int
        Stride of the kept steps (:func:`kept_every`; 1: every row, nothing else).
    chunk : int
        Steps per chunk.
    margins : int
        Margins checked per row (``len(layout.margins)``).

    Returns
    -------
    int
        Rows.
    """
    if every == 1:
        return n_steps + 1
    chunks = -(-n_steps // chunk) + 1                        # + the final state's row
    return n_steps // every + 1 + chunks * (margins + 4)


def estimate(links: int, step: float, duration: float, log_rate: float | None = None, logged: bool = True,
             block: int = 2000, layout: ChainLayout = PLANAR) -> Cost:
    """Cost of a run of ``links`` links for ``duration`` s at ``step`` (see :class:`Cost`).

    Parameters
    ----------
    links : int
        Links of the chain.
    step, duration : float
        RK4 step and simulated duration [s].
    log_rate : float, optional
        Samples per simulated second on the per-step channels [Hz] (default: every step).
    logged : bool
        Whether a log is written; without one every row stays in memory.
    block : int
        Steps per simulated block (one block is in flight at a time).
    layout : ChainLayout, optional
        The chain kind (:data:`~.log_layout.SPATIAL`: twice the values per link); default planar.

    Returns
    -------
    Cost
        Steps, uncompressed log bytes and bytes of run data in memory.
    """
    steps = int(math.ceil(duration / step))
    links = int(links)
    widths = numeric_channels(links) if layout is PLANAR else numeric_channels(links, layout=layout)
    row = sum(widths[k].width for k in PER_STEP) * 8          # float64 values of one sample
    record = row + len(PER_STEP) * (31 + 4)                    # + message headers and CDR headers
    every = max(1, int(round(1.0 / (log_rate * step)))) if log_rate else 1
    log_bytes = (steps // every + 1) * record if logged else 0
    kept = min(steps + 1, kept_capacity(steps, kept_every(None, logged, steps), block, len(layout.margins)))
    memory = 2 * kept * row + 4 * min(block, steps) * row      # a block copied into the kept rows doubles, one block in flight
    return Cost(steps, log_bytes, memory + LAW_BYTES_PER_LINK * links)


def machine_memory() -> int:
    """The machine's physical memory [bytes]: ``sysconf`` pages times page size where the system
    has them (Linux, macOS: the value ``psutil.virtual_memory().total`` reads, without importing
    psutil, which costs a run's start-up 15-20 ms), else ``psutil.virtual_memory().total``.

    Returns
    -------
    int
        Total physical memory [bytes].
    """
    try:
        pages, size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):       # no sysconf (Windows) or no such name
        pages = size = -1
    if pages > 0 and size > 0:
        return int(pages) * int(size)
    import psutil

    return int(psutil.virtual_memory().total)


def cost_limits() -> dict[str, int]:
    """The limits :func:`check_cost` applies: :data:`COST_LIMITS` with the memory limit raised to half the
    machine's memory.

    Returns
    -------
    dict of str to int
        ``steps``, ``log_bytes`` and ``memory_bytes`` limits.
    """
    return {**COST_LIMITS, "memory_bytes": max(COST_LIMITS["memory_bytes"], machine_memory() // 2)}


def check_cost(cost: Cost, confirmed: bool = False) -> None:
    """Refuse a run above :func:`cost_limits` unless ``confirmed``, and above the machine's memory always.

    Parameters
    ----------
    cost : Cost
        The run's estimate.
    confirmed : bool
        The user said yes (``--yes``): only the machine's memory is checked.

    Raises
    ------
    ConfigError
        Naming the estimate and the limit exceeded.
    """
    total = machine_memory()
    if cost.memory_bytes > total:
        raise ConfigError(f"this run needs {cost.describe()}, more than this machine's {_size(total)} of memory "
                          "(--yes does not lift this); use fewer links, shorten --duration or set --log-rate")
    if confirmed:
        return
    def show(name: str, value: int) -> str:
        return _size(value) if name.endswith("bytes") else f"{value:,}"

    over = [f"{name} {show(name, getattr(cost, name))} > {show(name, limit)}"
            for name, limit in cost_limits().items() if getattr(cost, name) > limit]
    if over:
        raise ConfigError(f"this run needs {cost.describe()} ({'; '.join(over)}); "
                          "pass --yes to run it anyway, or shorten --duration / lengthen --step / set --log-rate")


#: The optional ``[chain]`` keys of :mod:`.joint_rates`: the largest joint rate and acceleration.
RATE_KEYS = ("rate_limit", "accel_limit")


def check_limit(value: Any, field_name: str) -> float | None:
    """A ``rate_limit`` or ``accel_limit`` read from a scenario: None, or a finite number > 0.

    Parameters
    ----------
    value : object
        The value (None when the key is left out).
    field_name : str
        Its name in error messages (``"chain.rate_limit"``).

    Returns
    -------
    float or None
        The limit.

    Raises
    ------
    ConfigError
        Not a finite number > 0.
    """
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{field_name}: need a number > 0, got {value!r}")
    return float(value)


def rate_limits(chain: dict) -> tuple[float | None, float | None]:
    """``[chain] rate_limit`` and ``accel_limit`` of a scenario table, checked (:func:`check_limit`).

    Parameters
    ----------
    chain : dict
        The ``[chain]`` table.

    Returns
    -------
    tuple of (float or None, float or None)
        The rate limit [rad/s] and the acceleration limit [rad/s^2] (None when left out).
    """
    return tuple(check_limit(chain.get(k), f"chain.{k}") for k in RATE_KEYS)
