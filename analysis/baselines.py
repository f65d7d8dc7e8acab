"""Classic baselines on the same tasks as the coordinating law: end-point resolved-rate control.

Both baselines control only the central point ``y^m`` of the last link, the point whose arc
length ``s^m`` the coordinating law drives: its commanded velocity makes ``d psi / dt = v*``
along the curve and ``d phi / dt = -K phi`` across it (the same ``v*`` and gain ``K``), i.e.
``A qdot = r`` with the 2 x m task Jacobian ``A = [grad psi; grad phi] dy^m/dq`` and
``r = (v* - psi_t, -K phi - phi_t)``. The rest of the body is left to a null-space term.

* ``pinv``: ``qdot = A^+ r + (I - A^+ A) z`` with the Moore-Penrose pseudoinverse
  ``A^+ = A^T (A A^T)^-1`` and ``z = -k (q - q_c)``, the joint-centering gradient that pulls
  the joints towards the compact start configuration ``q_c`` (the zig-zag);
* ``dls``: the same with the damped inverse ``A^T (A A^T + lambda_v^2 I)^-1`` (variable
  damping of the ratio of singular values of ``A``, see :func:`symbolic.near_singular.damping_factor`).

The chains of the scenarios have ``B = I``, so ``u = qdot``. On a rail (``q = (d, q_1..q_m)``)
the rail is one more column of ``dy^m/dq`` (the rail direction: every centre slides with the
base) and the joint-centering term leaves ``d`` free (``z_d = 0``): it keeps the body compact,
not the base in place.

A spatial chain (:class:`~coordarm.symbolic.SpatialChain`, ``q = (a_1, b_1, ...)``, ``B = I``) has
three task rows (along the curve and the two normal coordinates ``Phi``) and a 3 x 3 Gram matrix
(:mod:`.spatial_baselines`); everything else is the same.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from coordarm.generated.build import build
from coordarm.generated.codegen import CODEGEN_OPTIONS, Source
from coordarm.simulation.choices import COMPARE_BACKENDS
from coordarm.simulation.run import Run
from coordarm.symbolic import ConfigError, CoordinatingController, PlanarChain, SpatialChain
from coordarm.symbolic.integrator import rk4
from coordarm.symbolic.near_singular import damping_factor

from .spatial_baselines import inverse3, singular_value_ratio3, spatial_end_point_task

#: Baselines implemented here.
BASELINES = ("pinv", "dls")
#: Gain of the joint-centering null-space term [1/s].
CENTERING_GAIN = 1.0
#: Backends of :func:`simulate_baseline`.
BACKENDS = COMPARE_BACKENDS
#: CasADi's generated functions are exported from the library (the build hides other symbols).
_EXPORT = '#define CASADI_SYMBOL_EXPORT __attribute__((visibility("default")))\n'


@dataclass
class EndPointRate:
    """End-point resolved-rate control of a chain (``pinv`` or ``dls``) as CasADi Functions.

    Attributes
    ----------
    ctrl : CoordinatingController
        Supplies the chain, the curve's geometry, the gain ``K`` [1/s] and ``v*(t)`` [m/s].
    centre : (dof,) ndarray
        Joint configuration the null-space term pulls towards [rad] (the compact start; on a
        rail its ``d`` is ignored).
    damping : dict, optional
        ``{"lambda": [m/rad], "band": [-]}`` for ``dls``; None for the pseudoinverse.
    centering : float
        Gain of the null-space joint-centering term [1/s].

    Raises
    ------
    ConfigError
        The chain's ``B`` is not the identity, or ``centre`` is not of shape ``(dof,)``.
    """

    ctrl: CoordinatingController
    centre: np.ndarray
    damping: dict | None = None
    centering: float = CENTERING_GAIN

    def __post_init__(self) -> None:
        chain = self.ctrl.chain
        if not isinstance(chain, SpatialChain) and (chain.b_diagonal is None or not np.all(chain.b_diagonal == 1)):
            raise ConfigError("baselines: need B = I (qdot = u)")
        self.centre = np.asarray(self.centre, dtype=float)
        if self.centre.shape != (chain.dof,):
            raise ConfigError(f"centre: need shape ({chain.dof},), got {self.centre.shape}")
        self._cache: dict = {}

    def _expressions(self):
        """``q``, ``t`` and ``(y^m, A, r, u)`` as SX expressions (O(m) operations)."""
        chain, ctrl = self.ctrl.chain, self.ctrl
        m = chain.m
        q, t = ca.SX.sym("q", chain.dof), ca.SX.sym("t")
        if isinstance(chain, SpatialChain):
            return self._spatial_expressions(q, t)
        weights = np.full(m, chain.xi)
        weights[[0, -1]] = 0.5 * chain.xi          # y^m = y^1 + sum_j w_j d(alpha_j)
        alpha = ca.cumsum(chain.revolute(q))
        c, s = ca.cos(alpha), ca.sin(alpha)
        y = ca.vertcat(ca.dot(weights, c), ca.dot(weights, s))
        # dy^m/dq_k = sum_{j >= k} w_j n(alpha_j): a reverse cumulative sum
        rev = list(range(m - 1, -1, -1))
        J = ca.horzcat(ca.cumsum((-weights * s)[rev])[rev], ca.cumsum((weights * c)[rev])[rev]).T
        free = np.ones(chain.dof)
        if chain.rail:                             # y^1 = d rail: the rail is the first column
            rail = ca.DM(chain.rail_direction)
            y, J, free[0] = y + q[0] * rail, ca.horzcat(rail, J), 0.0
        phi, g, phit, _, h, psit = ctrl.task.geometry(y, t)
        A = ca.vertcat(ca.mtimes(h.T, J), ca.mtimes(g.T, J))
        r = ca.vertcat(ctrl.speed(t) - psit, -ctrl.gain * phi - phit)
        G = ca.mtimes(A, A.T)
        if self.damping:
            tr, det = G[0, 0] + G[1, 1], G[0, 0] * G[1, 1] - G[0, 1] * G[1, 0]
            root = ca.sqrt(ca.fmax(tr * tr / 4 - det, 0))
            ratio = ca.sqrt(ca.fmax(tr / 2 - root, 0) / (tr / 2 + root))   # sigma_min / sigma_max of A
            G = G + damping_factor(ratio, self.damping["lambda"], self.damping["band"]) * ca.SX.eye(2)
        det = G[0, 0] * G[1, 1] - G[0, 1] * G[1, 0]
        Ginv = ca.vertcat(ca.horzcat(G[1, 1], -G[0, 1]), ca.horzcat(-G[1, 0], G[0, 0])) / det
        z = -self.centering * ca.DM(free) * (q - ca.DM(self.centre))
        u = ca.mtimes(A.T, ca.mtimes(Ginv, r)) + z - ca.mtimes(A.T, ca.mtimes(Ginv, ca.mtimes(A, z)))
        return q, t, y, A, r, u

    def _spatial_expressions(self, q: ca.SX, t: ca.SX):
        """:meth:`_expressions` of a spatial chain: three task rows (along, two across), a 3 x 3 Gram matrix."""
        y, A, r = spatial_end_point_task(self.ctrl, q, t)
        free = np.ones(self.ctrl.chain.dof)
        if self.ctrl.chain.rail:                   # the rail's d is left free by the centering term
            free[0] = 0.0
        G = ca.mtimes(A, A.T)
        if self.damping:
            lam2 = damping_factor(singular_value_ratio3(G), self.damping["lambda"], self.damping["band"])
            G = G + lam2 * ca.SX.eye(3)
        Ginv = inverse3(G)
        z = -self.centering * ca.DM(free) * (q - ca.DM(self.centre))
        u = ca.mtimes(A.T, ca.mtimes(Ginv, r)) + z - ca.mtimes(A.T, ca.mtimes(Ginv, ca.mtimes(A, z)))
        return q, t, y, A, r, u

    def law(self) -> ca.Function:
        """``(q, t) -> u`` (dof,) [rad/s; ``d_dot`` m/s first on a rail]; not finite where ``A A^T`` is singular (pinv).

        Built once, then kept.

        Returns
        -------
        casadi.Function
            ``(q (dof,) [rad], t [s]) -> u (dof,)``.
        """
        if "law" not in self._cache:
            q, t, _, _, _, u = self._expressions()
            self._cache["law"] = ca.Function("baseline_law", [q, t], [u], ["q", "t"], ["u"])
        return self._cache["law"]

    def task(self, q, t: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``y^m`` [m], the task Jacobian ``A`` [m/rad] and the commanded rates ``r`` [m/s] (k = 2 planar, 3 spatial).

        Parameters
        ----------
        q : (dof,) array_like
            Configuration [rad] (on a rail, ``d`` [m] first).
        t : float, optional
            Time [s].

        Returns
        -------
        y : (k,) ndarray
            Central point ``y^m`` of the last link [m].
        A : (k, dof) ndarray
            Task Jacobian (along, across the curve; spatial: across in ``n_1``, ``n_2``) [m/rad].
        r : (k,) ndarray
            Commanded rates ``(v* - psi_t, -K phi - phi_t)`` [m/s].

        Raises
        ------
        ConfigError
            ``q`` is not a finite configuration of the chain.
        """
        if "task" not in self._cache:
            qs, ts, y, A, r, _ = self._expressions()
            self._cache["task"] = ca.Function("baseline_task", [qs, ts], [y, A, r])
        y, A, r = self._cache["task"](self.ctrl.chain.check_q(q), t)
        return np.asarray(y).ravel(), np.asarray(A), np.asarray(r).ravel()

    def control(self, q, t: float = 0.0) -> np.ndarray:
        """``u = qdot`` (dof,) [rad/s].

        Parameters
        ----------
        q : (dof,) array_like
            Configuration [rad] (on a rail, ``d`` [m] first).
        t : float, optional
            Time [s].

        Returns
        -------
        (dof,) ndarray
            The input [rad/s] (on a rail, ``d_dot`` [m/s] first); not finite where ``A A^T`` is
            singular (pinv).

        Raises
        ------
        ConfigError
            ``q`` is not a finite configuration of the chain.
        """
        return np.asarray(self.law()(self.ctrl.chain.check_q(q), t)).ravel()

    def chunk(self, step: float, n: int, backend: str = "interpreted") -> ca.Function:
        """``n`` RK4 steps: ``(q0, t[1 x n]) -> (Q, U)``, column k the state after step k and ``u`` at its start.

        ``backend="compiled"``: the same Function as generated C, built (or taken from the
        build cache, see :func:`generated.build.build`) and loaded with ``casadi.external``.
        Built once per ``(step, n, backend)``, then kept.

        Parameters
        ----------
        step : float
            RK4 step [s].
        n : int
            Steps per call.
        backend : {"interpreted", "compiled"}, optional
            CasADi's virtual machine (the expanded SX Function) or generated C.

        Returns
        -------
        casadi.Function
            ``(q0 (dof,), t (1, n) [s]) -> (Q (dof, n), U (dof, n))``.

        Raises
        ------
        ConfigError
            Unknown ``backend``.
        BuildError
            ``backend="compiled"`` and the C code cannot be built.
        """
        if backend not in BACKENDS:
            raise ConfigError(f"backend: expected one of {BACKENDS}, got {backend!r}")
        key = ("chunk", float(step), n, backend)
        if key not in self._cache:
            name = "baseline_chunk"   # one named Function (mapaccum may nest and rename itself)
            rk4 = rk4_function(self.law(), step)
            acc = (rk4 if backend == "compiled" else rk4.expand()).mapaccum("steps", n)
            q0, times = ca.MX.sym("q0", self.ctrl.chain.dof), ca.MX.sym("t", 1, n)
            fn = ca.Function(name, [q0, times], acc(q0, times), ["q0", "t"], ["Q", "U"])
            if backend == "compiled":
                fn = compiled(fn, "dls" if self.damping else "pinv", self.ctrl.chain.m)
            self._cache[key] = fn
        return self._cache[key]


def compiled(fn: ca.Function, kind: str, m: int) -> ca.Function:
    """``fn`` as generated C: built (or taken from the build cache) and loaded with ``casadi.external``.

    Parameters
    ----------
    fn : casadi.Function
        The Function to generate (its name names the C symbol).
    kind : str
        What it is (part of the cache entry's description, e.g. ``"pinv"``).
    m : int
        Number of links (likewise).

    Returns
    -------
    casadi.Function
        The external Function, same inputs and outputs as ``fn``.

    Raises
    ------
    BuildError
        No C compiler, or the generated code did not compile or load.
    """
    cg = ca.CodeGenerator("baseline", dict(CODEGEN_OPTIONS))
    cg.add(fn)
    lib = build(Source(_EXPORT + cg.dump(), kind, m))
    return ca.external(fn.name(), str(lib.path))


def mapped_once(cache: dict, fn: ca.Function, kind: str, m: int, n: int, backend: str) -> ca.Function:
    """``fn`` mapped over ``n`` samples, as generated C for ``backend="compiled"``; kept in ``cache``.

    The compiled ``fn`` is built once (under ``cache["compiled"]``) and shared by every ``n``; each map is
    kept under ``("map", n, backend)``.

    Parameters
    ----------
    cache : dict
        The owner's cache of built Functions (written to).
    fn : casadi.Function
        The Function of one sample.
    kind : str
        What it is, for the build cache (see :func:`compiled`), e.g. ``"ftl"``.
    m : int
        Number of links (likewise).
    n : int
        Number of samples.
    backend : {"compiled", "interpreted"}
        Generated C (built or taken from the build cache), or CasADi's virtual machine.

    Returns
    -------
    casadi.Function
        ``fn.map(n)`` of the chosen backend.

    Raises
    ------
    ConfigError
        Unknown ``backend``.
    BuildError
        ``backend="compiled"`` and the C code cannot be built.
    """
    if backend not in BACKENDS:
        raise ConfigError(f"backend: expected one of {BACKENDS}, got {backend!r}")
    key = ("map", n, backend)
    if key not in cache:
        if backend == "compiled":
            if "compiled" not in cache:
                cache["compiled"] = compiled(fn, kind, m)
            fn = cache["compiled"]
        cache[key] = fn.map(n)
    return cache[key]


def stop_at_rail_limit(run: Run, chain: PlanarChain) -> Run:
    """``run`` up to its last sample inside the rail's limits (then ``info["stopped"] = "rail_limit"``).

    A robot's rail cannot feed the body beyond its ends; every method of ``coordarm compare`` is
    held to that (a fixed base, or a run inside the limits, is returned as it is).

    Parameters
    ----------
    run : Run
    chain : PlanarChain
        Its ``rail_limits`` [m].

    Returns
    -------
    Run
    """
    if not chain.rail:
        return run
    lo, hi = chain.rail_limits
    outside = ~((run.q[:, 0] >= lo) & (run.q[:, 0] <= hi))
    if not outside.any():
        return run
    end = max(int(np.argmax(outside)), 1)
    return run.rows(slice(0, end), dict(run.info, stopped="rail_limit"))


def rk4_function(law: ca.Function, h: float) -> ca.Function:
    """``(q, t) -> (q_next, u)``: one RK4 step of length ``h`` of ``qdot = law(q, t)``.

    An MX Function calling ``law`` four times (generated C keeps one copy of the law);
    ``.expand()`` it for CasADi's virtual machine.

    Parameters
    ----------
    law : casadi.Function
        ``(q (dof,), t) -> u (dof,)``, the right-hand side ``qdot`` (``B = I``).
    h : float
        Step length [s].

    Returns
    -------
    casadi.Function
        ``(q, t) -> (q_next, u)``: the state after the step and ``u`` at its start.
    """
    q, t = ca.MX.sym("q", law.size1_in(0)), ca.MX.sym("t")
    u = law(q, t)
    return ca.Function("rk4", [q, t], [rk4(law, q, t, h, k1=u), u], ["q", "t"], ["q_next", "u"])


def simulate_baseline(law: EndPointRate, q0, duration: float, step: float, t0: float = 0.0,
                      chunk: int = 2000, backend: str = "interpreted") -> Run:
    """Fixed-step RK4 of ``qdot = law(q, t)``, chunk by chunk (the same ``chunk`` steps each call).

    ``backend``: CasADi's virtual machine or generated C (see :meth:`EndPointRate.chunk`). The run stops (``info["stopped"] = "singularity"``) at the first non-finite state or
    control. ``e``, ``s`` and the margins of the returned :class:`~simulation.run.Run` are
    NaN (score runs from ``q`` with :mod:`analysis.compare`); ``info["wall_time"]`` is the
    time of the stepping loop [s] and ``info["steps"]`` its number of steps.

    Parameters
    ----------
    law : EndPointRate
        The baseline.
    q0 : (dof,) array_like
        Start configuration [rad] (on a rail, ``d`` [m] first).
    duration, step, t0 : float
        Simulated time, RK4 step and start time [s].
    chunk : int, optional
        Steps per call of the chunk Function (at most the run's steps).
    backend : {"interpreted", "compiled"}, optional
        How the chunk Function runs.

    Returns
    -------
    Run
        ``t`` ``(N,)`` [s], ``q`` and ``u`` ``(N, dof)``; after a singularity, up to the start of the
        first step whose state or control is not finite (that row's ``u`` may be the non-finite one).

    Raises
    ------
    ConfigError
        A bad ``q0`` or ``backend``; ``duration``, ``step`` or ``t0`` not finite, ``duration`` or ``step`` not
        > 0, or ``step > duration`` (named).
    BuildError
        ``backend="compiled"`` and the C code cannot be built.
    """
    from coordarm.simulation.run import check_time_span   # here, not at the top: spares a merge conflict

    duration, step, t0 = check_time_span(duration, step, t0)
    n_steps = int(round(duration / step))
    q = law.ctrl.chain.check_q(q0, "q0")
    chunk = min(chunk, n_steps)
    fn = law.chunk(step, chunk, backend)             # built before the clock starts
    Qs, Us, k, stopped = [], [], 0, "completed"
    wall = time.perf_counter()
    while k < n_steps:
        n = min(chunk, n_steps - k)                  # the last call runs past the end: its tail is dropped
        Qn, Un = (np.asarray(x).T[:n] for x in fn(q, t0 + step * np.arange(k, k + chunk)))
        good = np.isfinite(Qn).all(axis=1) & np.isfinite(Un).all(axis=1)
        if not good.all():
            bad = int(np.argmin(good))
            Qs.append(np.vstack([q[None], Qn[:bad]])[:bad + 1])
            Us.append(Un[:bad + 1])
            k += bad
            stopped = "singularity"
            break
        Qs.append(np.vstack([q[None], Qn[:-1]]))
        Us.append(Un)
        q, k = Qn[-1], k + n
    else:
        Qs.append(q[None])
        Us.append(law.control(q, t0 + step * k)[None])
    wall = time.perf_counter() - wall
    Q, U = np.concatenate(Qs), np.concatenate(Us)
    T = t0 + step * np.arange(len(Q))
    return Run.from_states(T, Q, U, law.ctrl.speeds(T), law.ctrl.chain.m,
                           info={"backend": backend, "stopped": stopped, "wall_time": wall, "steps": max(k, 1)})
