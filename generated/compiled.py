"""The compiled controller: the generated library loaded with ctypes, with a lean call path.

Buffers (state, outputs, CasADi work arrays) are allocated once per object, so a call
from Python is one ctypes call plus a copy of ``u`` out, or, with ``out=``, no copy at all
(a float64 C-contiguous ``q`` is read in place).
"""
from __future__ import annotations

import ctypes
import math
import sys
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from coordarm.symbolic import BuildError, ConfigError, CoordinatingController, NonFiniteError
from coordarm.symbolic.checks import is_real
from coordarm.symbolic.errors import shown
from coordarm.symbolic.outputs import packed_width, spatial_packed_width, spatial_split, split

from .build import Library
from .source import Source
from .source_memo import compiled_library

if TYPE_CHECKING:   # a planar run does not load the spatial modules
    from coordarm.symbolic import SpatialController

_P, _D, _I = ctypes.c_void_p, ctypes.c_double, ctypes.c_longlong
_SIGNATURES = {"coordarm_law": [_P, _D, _P, _P, _P],
               "coordarm_control": [_P, _D, _P, _P, _P, _P],
               "coordarm_rk4": [_P, _D, _D, _P, _P, _P, _P],
               "coordarm_chunk": [_P, _P, _D, _I, _P, _P, _P, _P]}


def flushes_subnormals() -> bool:
    """True when this thread's floating point flushes subnormal numbers to zero (FTZ/DAZ).

    Returns
    -------
    bool
        Whether ``2.2250738585072014e-308 / 2`` (a subnormal) comes out as 0.
    """
    return float(np.float64(2.2250738585072014e-308) / np.float64(2.0)) == 0.0


def load_library(path) -> ctypes.CDLL:
    """Load a generated library and declare its functions' argument types.

    Parameters
    ----------
    path : str or Path
        The shared library.

    Returns
    -------
    ctypes.CDLL
        The loaded library, its API functions typed.

    Raises
    ------
    BuildError
        The file is not a loadable library or lacks the coordarm API.

    Warns
    -----
    RuntimeWarning
        Loading it switched the process to flush-to-zero arithmetic (a library linked with
        ``-ffast-math`` by gcc < 13 does so; numpy is affected too).
    """
    ftz_before = flushes_subnormals()
    try:
        lib = ctypes.CDLL(str(path))
        for name, argtypes in _SIGNATURES.items():
            f = getattr(lib, name)
            f.argtypes, f.restype = argtypes, ctypes.c_int
        lib.coordarm_sizes.argtypes, lib.coordarm_sizes.restype = [_P], None
    except (OSError, AttributeError) as exc:
        raise BuildError(f"cannot load generated library {path}: {exc}") from None
    if flushes_subnormals() and not ftz_before:
        warnings.warn(f"loading {path} switched this process to flush-to-zero arithmetic (subnormal numbers "
                      "now read as 0, in numpy too): it was linked with -ffast-math or similar; build without "
                      "it, or add -mno-daz-ftz (gcc >= 13) to COORDARM_CFLAGS", RuntimeWarning, stacklevel=2)
    return lib


def is_spatial(ctrl: Any) -> bool:
    """Whether ``ctrl`` is a :class:`~coordarm.symbolic.SpatialController` (without importing its module: if it
    was never imported, there is none).

    Parameters
    ----------
    ctrl : object
        A controller.

    Returns
    -------
    bool
    """
    module = sys.modules.get("coordarm.symbolic.spatial_controller")
    return module is not None and isinstance(ctrl, module.SpatialController)


def controller_source(ctrl: CoordinatingController | SpatialController, form: str,
                      path_search: bool = True) -> Source:
    """The C source of a planar or a spatial controller's law.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The controller.
    form : {"structured", "dense"}
        Law form.
    path_search : bool
        See :func:`generated.codegen.structured_law` (planar paths only).

    Returns
    -------
    Source
        The C text.

    Raises
    ------
    BuildError
        A non-diagonal B or an unknown form.
    """
    if is_spatial(ctrl):
        from .spatial_codegen import generate_spatial_source
        return generate_spatial_source(ctrl, form)
    from .codegen import generate_source
    return generate_source(ctrl, form, path_search)


class CompiledController:
    """A :class:`~symbolic.CoordinatingController`'s law, RK4 step and chunk loop as compiled C.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The controller to compile (a planar chain needs a diagonal B); a spatial controller's
        outputs are packed as :func:`coordarm.symbolic.outputs.spatial_offsets` says.
    form : {"structured", "dense"}
        Law form.
    cc : str, optional
        C compiler (see :func:`generated.build.build`).
    flags : sequence of str or str, optional
        Optimisation flags (see :func:`generated.build.build`).
    build_dir : path, optional
        Cache directory (see :func:`generated.build.build`).
    force : bool
        Recompile even on a cache hit.
    path_search : bool
        On a path, the C glue searches the closest piece near the previous link's (default); False
        selects it over every piece inside the generated step (the slower reference form).
    library : Library, optional
        The library of this controller's law, already found in the cache
        (:func:`~coordarm.generated.source_memo.remembered_library`): loaded as it is.

    Attributes
    ----------
    library : Library
        Path, cache key, whether the build hit the cache, compile time.
    generate_seconds : float
        Time spent generating the C source [s]: 0 when the library of the controller's recipe was
        remembered (:mod:`.source_memo`: the C is then not generated).

    Raises
    ------
    BuildError
        The library cannot be built or loaded (see :func:`generated.build.build`), or it was built
        for another link count or output width.

    Notes
    -----
    The buffers are shared by all calls of one object: use one object per thread.
    """

    def __init__(self, ctrl: CoordinatingController | SpatialController, form: str = "structured", *,
                 cc: str | None = None,
                 flags=None, build_dir=None, force: bool = False, path_search: bool = True,
                 library: Library | None = None) -> None:
        self.ctrl, self.form, self.chain = ctrl, form, ctrl.chain
        self.library: Library
        self.library, self.generate_seconds = (library, 0.0) if library is not None else compiled_library(
            ctrl, form, path_search, lambda: controller_source(ctrl, form, path_search), cc=cc, flags=flags,
            build_dir=build_dir, force=force)
        self._lib = load_library(self.library.path)
        sizes = np.zeros(4, dtype=np.int64)
        self._lib.coordarm_sizes(sizes.ctypes.data)
        m, self.n_out, n_iw, n_w = (int(v) for v in sizes)
        self.rail = self.chain.rail
        spatial = is_spatial(ctrl)
        width = spatial_packed_width(self.chain.m, self.rail) if spatial else packed_width(self.chain.m, self.rail)
        self._split = ((lambda packed: spatial_split(packed, self.m, self.rail)) if spatial
                       else (lambda packed: split(packed, self.m, self.rail)))
        if m != self.chain.m or self.n_out != width:
            raise BuildError(f"generated library {self.library.path} is for {m} links and {self.n_out} outputs, "
                             f"not {self.chain.m} and {width}")
        #: Number of links ``m`` and of joints ``n`` (``m + 1`` on a rail: ``d`` first).
        self.m, self.n = m, self.chain.dof
        self._q = np.zeros(self.n)
        self._out = np.zeros(self.n_out)
        self._qn = np.zeros(self.n)
        self._iw = np.zeros(n_iw, dtype=np.int64)
        self._w = np.zeros(n_w)
        self._ptr = (self._q.ctypes.data, self._out.ctypes.data, self._iw.ctypes.data, self._w.ctypes.data,
                     self._qn.ctypes.data)
        self._law_c, self._rk4_c, self._chunk_c = (self._lib.coordarm_law, self._lib.coordarm_rk4,
                                                   self._lib.coordarm_chunk)
        self._control_c = self._lib.coordarm_control
        # one-slot caches of caller arrays used in place: (array, its data pointer); holding the
        # array keeps its buffer alive and fixed (numpy refuses to resize a referenced array)
        self._seen = {"q": (None, 0), "u": (None, 0), "out": (None, 0)}

    @property
    def cache_hit(self) -> bool:
        """Whether the library came from the build cache."""
        return self.library.cache_hit

    def _load_q(self, q) -> None:
        if type(q) is np.ndarray and q.shape == self._q.shape:
            self._q[:] = q
        else:
            self._q[:] = self.chain.check_q(q)

    def _in_place(self, role: str, a, size: int) -> int:
        """Data pointer of ``a`` if C can use it in place (float64, C-contiguous, ``size`` values), else 0."""
        seen, ptr = self._seen[role]
        if a is seen:
            return ptr
        if (type(a) is np.ndarray and a.dtype == np.float64 and a.shape == (size,) and a.flags.c_contiguous
                and (role == "q" or a.flags.writeable)):
            ptr = a.ctypes.data
            self._seen[role] = (a, ptr)
            return ptr
        return 0

    def _q_pointer(self, q) -> int:
        """``q``'s own buffer when it is a float64 C-contiguous (n,) array, else a checked copy's."""
        ptr = self._in_place("q", q, self.n)
        if ptr:
            return ptr
        self._load_q(q)
        return self._ptr[0]

    def _out_pointer(self, out, size: int, role: str) -> int:
        ptr = self._in_place(role, out, size)
        if not ptr:
            raise ConfigError(f"out: need a writeable C-contiguous float64 array of shape ({size},), "
                              f"got {type(out).__name__} {getattr(out, 'shape', '')}")
        return ptr

    def _fail(self, rc: int, t: float, q=None) -> None:
        if rc == 1:
            self.chain.check_q(self._q if q is None else q)
            raise ConfigError(f"t: must be finite, got {t!r}")
        if rc == 3:
            raise NonFiniteError(f"the compiled law produced a non-finite value at t = {t!r} "
                                 f"(a singular configuration, or the curve undefined there)")
        raise BuildError(f"generated library {self.library.path}: a generated Function failed (code {rc})")

    def control(self, q, t: float = 0.0, out: np.ndarray | None = None) -> np.ndarray:
        """Control ``u(q, t)``, shape (n,) (``n = m``; on a rail ``m + 1``, ``d_dot`` [m/s] first; spatial ``2 m``).

        Parameters
        ----------
        q : (n,) array_like
            Joint coordinates [rad] (``d`` [m] first on a rail); a float64 C-contiguous array is read in place.
        t : float
            Time [s].
        out : (n,) float64 ndarray, optional
            Write ``u`` [rad/s per unit of B] here, in place, and return it (no copies).

        Returns
        -------
        (n,) ndarray
            ``u`` [rad/s] (``d_dot`` [m/s] first on a rail): ``out`` itself when given, else a new array.

        Raises
        ------
        ConfigError
            ``q`` or ``t`` not finite, wrong shapes, or an unusable ``out``.
        NonFiniteError
            The law produced NaN or inf (a singular configuration, or the curve undefined at ``t``).
        """
        qp = self._q_pointer(q)
        if out is None:
            rc = self._law_c(qp, t, self._ptr[1], self._ptr[2], self._ptr[3])
            if rc:
                self._fail(rc, t, q)
            return self._out[:self.n].copy()
        up = self._out_pointer(out, self.n, "u")
        rc = self._control_c(qp, t, up, self._ptr[1], self._ptr[2], self._ptr[3])
        if rc:
            self._fail(rc, t, q)
        return out

    def evaluate(self, q, t: float = 0.0, out: np.ndarray | None = None) -> dict[str, Any]:
        """All outputs of the law at ``(q, t)``, keyed like :meth:`CoordinatingController.evaluate`.

        With ``out`` (a float64 array of the packed width, see :mod:`coordarm.symbolic.outputs`),
        the packed outputs are written there in place and the dict holds views of it.

        Parameters
        ----------
        q : (n,) array_like
            Joint coordinates [rad] (``d`` [m] first on a rail); a float64 C-contiguous array is read in place.
        t : float
            Time [s].
        out : (n_out,) float64 ndarray, optional
            Writeable C-contiguous buffer of the packed width ``n_out``.

        Returns
        -------
        dict
            Output name -> value (``u``, ``e``, ``s``, ...: :func:`coordarm.symbolic.outputs.split`);
            views of ``out`` when given, else of a fresh copy.

        Raises
        ------
        ConfigError
            ``q`` or ``t`` not finite, wrong shapes, or an unusable ``out``.
        NonFiniteError
            The law produced NaN or inf (a singular configuration, or the curve undefined at ``t``).
        """
        if out is None:
            self.control(q, t)
            return self._split(self._out.copy())
        qp = self._q_pointer(q)
        rc = self._law_c(qp, t, self._out_pointer(out, self.n_out, "out"), self._ptr[2], self._ptr[3])
        if rc:
            self._fail(rc, t, q)
        return self._split(out)

    def step(self, q, t: float, h: float) -> np.ndarray:
        """One closed-loop RK4 step of length ``h`` [s] from ``(q, t)``: the next state [rad] (``d`` [m] first on a rail).

        Parameters
        ----------
        q : (n,) array_like
            Joint coordinates [rad] (``d`` [m] first on a rail).
        t : float
            Time at the start of the step [s].
        h : float
            Step length [s].

        Returns
        -------
        (n,) ndarray
            The state after the step (a new array).

        Raises
        ------
        ConfigError
            ``q`` of the wrong shape or not finite, or ``t`` not finite.
        NonFiniteError
            The law produced NaN or inf (a singular configuration, or the curve undefined at ``t``).
        """
        self._load_q(q)
        p = self._ptr
        rc = self._rk4_c(p[0], t, h, p[4], p[1], p[2], p[3])
        if rc:
            self._fail(rc, t)
        return self._qn.copy()

    def chunk(self, q0, times: np.ndarray, h: float, *, with_start: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """RK4 steps of length ``h`` starting at each of ``times``, all in one call of C.

        Parameters
        ----------
        q0 : (n,) array_like
            State at ``times[0]`` [rad] (``d`` [m] first on a rail).
        times : (N,) array_like
            Start time of each step [s] (step k runs from ``times[k]`` to ``times[k] + h``).
        h : float
            Step length [s].
        with_start : bool
            Return the states with ``q0`` as their first row, ``(N + 1, n)``: ``Q[:-1]`` are the states at
            the steps' starts and ``Q[1:]`` after them, both views (no copy of a chunk's states).

        Returns
        -------
        Q : (N, n) ndarray
            State after each step (``with_start``: ``(N + 1, n)``, ``q0`` first).
        D : (N, n_out) ndarray
            The law at each step's start, packed (split it with
            :func:`coordarm.symbolic.outputs.split`; a spatial law's with
            :func:`~coordarm.symbolic.outputs.spatial_split`, layout :func:`~coordarm.symbolic.outputs.spatial_offsets`).

        Raises
        ------
        ConfigError
            ``q0`` of the wrong shape or not finite, ``times`` not a 1-D array of finite times, or ``h`` not a
            finite positive step.
        NonFiniteError
            The law produced NaN or inf.
        """
        self._load_q(q0)
        times, h = chunk_grid(times, h)
        n = len(times)
        S, D = np.empty((n + 1, self.n)), np.empty((n, self.n_out))
        p = self._ptr
        S[0] = self._q                 # q0 as C reads it
        rc = self._chunk_c(p[0], times.ctypes.data, h, n, S[1:].ctypes.data, D.ctypes.data, p[2], p[3])
        if rc:      # h and the times are checked above: only a failing generated Function is left
            self._fail(rc, float(times[0]) if n else 0.0)
        return (S if with_start else S[1:]), D

    def __repr__(self) -> str:
        return (f"CompiledController({self.ctrl!r}, form={self.form!r}, library={str(self.library.path)!r}, "
                f"cache_hit={self.cache_hit})")


def chunk_grid(times: Any, h: Any) -> tuple[np.ndarray, float]:
    """The start times and the step of :meth:`CompiledController.chunk`, checked, as C reads them.

    Parameters
    ----------
    times : (N,) array_like
        Start time of each step [s].
    h : float
        Step length [s].

    Returns
    -------
    times : (N,) float64 C-contiguous ndarray
        The start times [s].
    h : float
        The step [s].

    Raises
    ------
    ConfigError
        ``times`` not a 1-D sequence of finite numbers (naming the first bad entry), or ``h`` not a finite
        number above 0.
    """
    if not is_real(h, numpy=True) or not math.isfinite(h) or h <= 0:
        raise ConfigError(f"h: the step must be a finite number of seconds above 0, got {shown(h)}")
    try:
        grid = np.ascontiguousarray(times, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"times: need a 1-D sequence of start times [s], got {shown(times)}") from None
    if grid.ndim != 1:
        raise ConfigError(f"times: need a 1-D sequence of start times [s], got shape {grid.shape}")
    bad = np.flatnonzero(~np.isfinite(grid))
    if len(bad):
        raise ConfigError(f"times[{bad[0]}]: each start time must be finite, got {float(grid[bad[0]])!r}")
    return grid, float(h)
