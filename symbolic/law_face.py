"""What both controller faces share: the cached law, its fast form, the RK4 step and the evaluation.

:class:`LawFace` is the common base of :class:`~coordarm.symbolic.controller.CoordinatingController`
(planar) and :class:`~coordarm.symbolic.spatial_controller.SpatialController`. Its host provides
``chain``, ``task``, ``law_form``, ``outputs``, ``run_outputs`` and ``_cache`` (a dict), and the
face-specific pieces: the law builder, the expression of the dense decoupling matrix, the
Functions' names, the scalar outputs and how the control enters ``q'``.
"""
from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import casadi as ca
import numpy as np

from .digests import sha256
from .errors import ConfigError
from .laws import LAWS, Law


def condition_numbers(M: np.ndarray) -> np.ndarray:
    """2-norm condition numbers of a stack of square matrices.

    Parameters
    ----------
    M : ndarray, shape (N, n, n)
        The matrices.

    Returns
    -------
    ndarray, shape (N,)
        ``sigma_max / sigma_min`` of each (inf when singular).
    """
    sv = np.linalg.svd(M, compute_uv=False)
    with np.errstate(divide="ignore"):
        return sv[:, 0] / sv[:, -1]


def _array_digest(a: np.ndarray) -> bytes:
    """SHA-256 of an array's values, shape and type (its buffer read in place when contiguous: no copy)."""
    h = sha256(f"{a.dtype.str} {a.shape}".encode())
    try:
        h.update(memoryview(a).cast("B"))
    except (TypeError, ValueError):                     # not contiguous, 0-d, or objects: a copy
        h.update(a.tobytes())
    return h.digest()


class LawFace:
    """The law of a coordinating controller, cached per form, and its numeric evaluation.

    Attributes
    ----------
    law_form : {"structured", "dense"}
        The default law form.
    outputs, run_outputs : tuple of str
        Names of the law's outputs, and of those kept at every sample of a run.
    """

    chain: Any
    law_form: str
    outputs: Sequence[str]
    run_outputs: Sequence[str]
    _cache: dict
    #: Outputs returned as floats by :meth:`evaluate` (the others as arrays).
    SCALAR_OUTPUTS: Sequence[str] = ()
    #: Names of the Functions of :meth:`rk4_step` and :meth:`decoupling_function`.
    RK4_NAME, DECOUPLING_NAME = "rk4_step", "decoupling"

    def _build_law(self, form: str) -> ca.Function:
        """The law ``(q, t) -> outputs`` of ``form``, uncached (provided by the face)."""
        raise NotImplementedError

    def _decoupling_expr(self, q: ca.SX, t: ca.SX) -> tuple[ca.SX, ca.SX]:
        """The dense decoupling matrix and right-hand side at symbols ``(q, t)`` (provided by the face)."""
        raise NotImplementedError

    def _expands(self, form: str) -> bool:
        """Whether :meth:`fast_law` expands the law of ``form`` to SX (the structured form)."""
        return form == Law.STRUCTURED

    def _input_matrix(self) -> Callable[[Any], Any] | None:
        """``u -> q'`` when it is not the identity (``B = I``), else None."""
        return None

    def _check_time(self, t: Any) -> None:
        """Raise :class:`ConfigError` unless ``t`` is a finite time."""
        if not math.isfinite(t):
            raise ConfigError(f"t: must be finite, got {t!r}")

    def set_recipe(self, text: str) -> None:
        """Declare that ``text`` (with coordarm's code) determines this controller, hence its generated C.

        :meth:`coordarm.simulation.scenario.Scenario.controller` declares the scenario's JSON; the
        compiled backend then finds the library of a known recipe without generating its C
        (:mod:`coordarm.generated.source_memo`). The declaration lapses (:attr:`recipe` is None) once an
        attribute of the controller, of its chain, curve or task is replaced or an array of theirs changes.

        Parameters
        ----------
        text : str
            The description the controller was built from, and nothing else.
        """
        self._recipe = (text, self._recipe_state())

    @property
    def recipe(self) -> str | None:
        """The text given to :meth:`set_recipe`; None without one, or once the controller was changed."""
        recipe = getattr(self, "_recipe", None)
        if recipe is None:
            return None
        text, then = recipe
        now = self._recipe_state()
        same = now is not None and then is not None and len(now) == len(then) and all(
            a[0] == b[0] and a[1] is b[1] and a[2] == b[2] for a, b in zip(then, now))
        return text if same else None

    def _recipe_state(self) -> list[tuple[str, Any, bytes | None]] | None:
        """The attributes of the controller, its chain, curve and task (objects held, arrays' bytes), or None."""
        state = []
        for owner in (self, self.chain, getattr(self, "curve", None), getattr(self, "task", None)):
            try:
                items = vars(owner).items()
            except TypeError:                          # no __dict__: nothing to compare
                return None
            state += [(name, value, _array_digest(value) if isinstance(value, np.ndarray) else None)
                      for name, value in items if not (owner is self and name in ("_cache", "_recipe"))]
        return state

    def law(self, form: str | None = None) -> ca.Function:
        """The control law ``(q, t) -> outputs``, named and ordered as :attr:`outputs`.

        ``form="structured"`` is an MX Function with a loop over links (``mapaccum``, for code
        generation); ``form="dense"`` solves the dense decoupling system.

        Parameters
        ----------
        form : {"structured", "dense"}, optional
            Law form (default: the controller's).

        Returns
        -------
        casadi.Function
            ``(q, t) -> outputs`` (cached per form).

        Raises
        ------
        ConfigError
            Unknown form.
        """
        form = form or self.law_form
        if form not in LAWS:
            raise ConfigError(f"law: expected one of {LAWS}, got {form!r}")
        key = ("law", form)
        if key not in self._cache:
            self._cache[key] = self._build_law(form)
        return self._cache[key]

    def fast_law(self, form: str | None = None) -> ca.Function:
        """:meth:`law` expanded to a flat SX Function: fastest in CasADi's interpreter.

        Parameters
        ----------
        form : {"structured", "dense"}, optional
            Law form (default: the controller's).

        Returns
        -------
        casadi.Function
            Same inputs and outputs as :meth:`law`.
        """
        form = form or self.law_form
        key = ("fast", form)
        if key not in self._cache:
            law = self.law(form)
            self._cache[key] = law.expand() if self._expands(form) else law
        return self._cache[key]

    def rk4_step(self, h: float, form: str | None = None) -> ca.Function:
        """Closed-loop RK4 step of ``q' = B u(q, t)``: ``(q, t) -> (q_next, *run_outputs)``.

        The diagnostics (:attr:`run_outputs`) are those of the law at the step's start ``(q, t)``.

        Parameters
        ----------
        h : float
            Step length [s].
        form : {"structured", "dense"}, optional
            Law form (default: the controller's).

        Returns
        -------
        casadi.Function
            ``(q, t) -> (q_next, *run_outputs)`` (cached per form and ``h``).
        """
        form = form or self.law_form
        key = ("rk4", form, float(h))
        if key not in self._cache:
            from .integrator import rk4          # here: a compiled run steps in C

            law = self.fast_law(form)
            apply_B = self._input_matrix() or (lambda u: u)
            q, t = ca.MX.sym("q", self.chain.dof), ca.MX.sym("t")
            out1 = law(q, t)                              # kept: the diagnostics at the step's start
            q_next = rk4(lambda x, s: apply_B(law(x, s)[0]), q, t, h, k1=apply_B(out1[0]))
            kept = [out1[self.outputs.index(name)] for name in self.run_outputs]
            self._cache[key] = ca.Function(self.RK4_NAME, [q, t], [q_next, *kept],
                                           ["q", "t"], ["q_next", *self.run_outputs])
        return self._cache[key]

    def decoupling_function(self) -> ca.Function:
        """``(q, t) -> (M, rhs)``: the dense decoupling matrix and its right-hand side.

        Returns
        -------
        casadi.Function
            The AD form (O(m^2) graph), cached.
        """
        if "M" not in self._cache:
            q, t = ca.SX.sym("q", self.chain.dof), ca.SX.sym("t")
            M, r = self._decoupling_expr(q, t)
            self._cache["M"] = ca.Function(self.DECOUPLING_NAME, [q, t], [M, r], ["q", "t"], ["M", "rhs"])
        return self._cache["M"]

    def evaluate(self, q: Any, t: float = 0.0, form: str | None = None, once: bool = False) -> dict[str, Any]:
        """All outputs of the law at ``(q, t)`` as numpy values, keyed by :attr:`outputs`.

        Parameters
        ----------
        q : array_like, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).
        t : float
            Time [s].
        form : {"structured", "dense"}, optional
            Law form (default: the controller's).
        once : bool
            A single evaluation: :meth:`law` as built, not expanded to :meth:`fast_law` (unless that
            exists already), which costs more than one call (2.7 ms at 64 links, 40 ms on a path of 80);
            the numbers are the same (``tests/test_law_face.py`` checks them bit for bit).

        Returns
        -------
        dict
            Vectors as arrays, scalars (:attr:`SCALAR_OUTPUTS`) as floats.

        Raises
        ------
        ConfigError
            ``q`` or ``t`` not finite, or ``q`` of the wrong shape.
        """
        q = self.chain.check_q(q)
        self._check_time(t)
        fast = self._cache.get(("fast", form or self.law_form))
        res = (self.law(form) if once and fast is None else self.fast_law(form))(q, t)
        out: dict[str, Any] = {}
        for name, v in zip(self.outputs, res):
            v = np.asarray(v, dtype=float).ravel()
            out[name] = float(v[0]) if name in self.SCALAR_OUTPUTS else v
        return out

    def control(self, q: Any, t: float = 0.0) -> np.ndarray:
        """Control ``u(q, t)``.

        Parameters
        ----------
        q : array_like, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (dof,)
            The control [rad/s for B = I] (``d_dot`` [m/s] first on a rail).
        """
        return self.evaluate(q, t)["u"]
