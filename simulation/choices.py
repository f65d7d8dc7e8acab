"""Choices the command line offers, kept free of heavy imports so that ``coordarm --help`` starts at once.

The modules that act on them (:mod:`coordarm.simulation.run`, :mod:`.mcap_file`, :mod:`.scenario`, :mod:`.sweep_points`) import
them from here.
"""
from __future__ import annotations

from enum import StrEnum
from importlib import import_module
from types import ModuleType

from coordarm.symbolic.errors import ConfigError
from coordarm.symbolic.lazy import package_folder

class Backend(StrEnum):
    """How a run evaluates the law; a member equals (and prints as) its string value.

    ``AUTO`` = compiled when a C compiler builds the library, else interpreted (with a warning);
    ``COMPILED``: the generated C; ``INTERPRETED``: CasADi's virtual machine.
    """

    AUTO = "auto"
    COMPILED = "compiled"
    INTERPRETED = "interpreted"


class Compression(StrEnum):
    """Chunk compression of the run log (all in the MCAP specification and read by Foxglove).

    ``LZ4`` (frame format, the default: compresses a 64-link full-rate log 2-3x faster than zstd, for a
    file about 1.4x larger), ``ZSTD`` (level 1, the smallest file) and ``NONE`` (chunks stored as they
    are, a 2.6x larger file at 64 links); :data:`DEFAULT_COMPRESSION`.
    """

    LZ4 = "lz4"
    NONE = "none"
    ZSTD = "zstd"


class Outcome(StrEnum):
    """How a run ended (the log's ``outcome`` status and a sweep row's ``outcome``).

    A member equals (and prints as) its string value.
    """

    COMPLETED = "completed"
    SINGULARITY = "singularity"
    BASE_OFF_PATH = "base_off_path"
    COLLISION = "collision"
    RATE_LIMIT = "rate_limit"
    INTERRUPTED = "interrupted"
    ERROR = "error"


#: The backends as plain strings (argparse choices and error messages).
BACKENDS = tuple(b.value for b in Backend)
#: The log's chunk compression unless one is asked for (``--compression``; benchmarks/RESULTS.md, issue 24).
DEFAULT_COMPRESSION = Compression.LZ4.value
#: The compressions as plain strings, sorted (argparse choices and error messages).
COMPRESSIONS = tuple(c.value for c in Compression)
#: Methods of ``coordarm compare`` (:mod:`coordarm.analysis.compare`), in table order.
COMPARE_METHODS = ("coordinating", "pinv", "dls", "ftl")
#: Backends of ``coordarm compare``: every method as generated C, or in CasADi's virtual machine.
COMPARE_BACKENDS = (Backend.COMPILED.value, Backend.INTERPRETED.value)
#: Links above which the dense law's code generation and compilation take minutes (``coordarm run --yes``).
DENSE_LINKS = 128
#: Rows a logged run without figures keeps in memory (about; with figures :data:`~.limits.KEEP_ROWS`): its
#: summary takes its maxima from every step or from each chunk's extreme rows (:mod:`.every_step`), its
#: clearances from at most 2000 rows.
SUMMARY_ROWS = 2_000
#: Short names accepted by ``coordarm sweep --vary`` (the results column keeps the name as given).
SWEEP_ALIASES = {"links": "chain.links", "link_length": "chain.link_length", "gain": "control.gain",
                 "speed": "control.speed", "beta": "start.beta", "heading": "start.heading",
                 "duration": "run.duration", "step": "run.step", "radius": "curve.radius", "angle": "curve.angle"}


def presets() -> list[str]:
    """Names of the scenarios shipped with coordarm (the TOML files in ``coordarm.simulation.presets``).

    Returns
    -------
    list of str
        Sorted preset names, e.g. ``["arc", "hole", "line"]``.
    """
    return sorted(p.name[:-5] for p in package_folder("coordarm.simulation", "presets").iterdir()
                  if p.name.endswith(".toml"))


def lz4_frame() -> ModuleType:
    """The ``lz4.frame`` module, imported on first need (imported only when a log uses it).

    Returns
    -------
    module
        ``lz4.frame``.

    Raises
    ------
    ConfigError
        lz4 is not installed (the message says how to install it).
    """
    try:
        return import_module("lz4.frame")
    except ImportError:
        raise ConfigError("compression lz4: the lz4 package is not installed; "
                          "install it with: pip install lz4 (or use --compression zstd)") from None
