"""LTI error model of one task coordinate (python-control): sampled-data and delay limits.

Every deviation obeys ``edot = u_e`` with ``u_e = -K e`` (the law cancels the rest, see
:mod:`analysis.linearise`). A digital controller samples every ``h``, holds its output
(zero-order hold) and applies it ``n`` samples late, so the loop is

    L(z) = K * ZOH{1/s}(z) * z^{-n} = K h / (z - 1) * z^{-n},

closed-loop characteristic polynomial ``z^{n+1} - z^n + K h``. It is stable exactly for
``K h < 2 sin(pi / (2 (2 n + 1)))`` (n = 0: ``K h < 2``; n = 1: ``K h < 1``). The continuous
loop ``K e^{-s tau} / s`` has phase margin 90 deg at crossover ``K``: delay margin
``tau < pi / (2 K)``. RK4 integration of ``edot = -K e`` is stable for ``K h < 2.7853``.
:func:`simulated_limit` checks a limit on the real nonlinear closed loop with
:func:`simulation.sampled.simulate_sampled`.
"""
from __future__ import annotations

import warnings
from collections.abc import Sequence

import control as ct
import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from coordarm.simulation.run import check_number
from coordarm.simulation.limits import RK4_LIMIT, sampled_limit  # noqa: F401 (re-exported; derived here)
from coordarm.simulation.sampled import check_delay
from coordarm.symbolic import ConfigError, CoordinatingController



def _check(gain: float, period: float | None = None, delay: int = 0) -> None:
    for name, v in (("gain", gain), ("period", period)):
        if v is not None:
            check_number(v, name)
    check_delay(delay)


def error_loop(gain: float, period: float | None = None, delay: int = 0) -> ct.TransferFunction:
    """Open loop of one deviation: ``K / s`` (``period`` None) or ``K h z^{-n} / (z - 1)`` (ZOH, delayed).

    Parameters
    ----------
    gain : float
        Error gain K > 0 [1/s].
    period : float or None
        Sampling period h > 0 [s]; None: the continuous loop.
    delay : int
        Control delay n >= 0 [samples].

    Returns
    -------
    control.TransferFunction
        The loop (continuous, or discrete with time step ``period``).

    Raises
    ------
    ConfigError
        ``gain`` or ``period`` not a positive finite number, or ``delay`` not an integer >= 0.
    """
    _check(gain, period, delay)
    plant = ct.tf([1.0], [1.0, 0.0])
    if period is None:
        return gain * plant
    late = ct.tf([1.0], [1.0] + [0.0] * delay, dt=period)
    return gain * ct.c2d(plant, period, "zoh") * late


def error_closed_loop(gain: float, period: float | None = None, delay: int = 0) -> ct.TransferFunction:
    """Closed loop ``e_ref -> e`` (unit negative feedback around :func:`error_loop`).

    Parameters
    ----------
    gain : float
        Error gain K > 0 [1/s].
    period : float or None
        Sampling period h > 0 [s]; None: the continuous loop.
    delay : int
        Control delay n >= 0 [samples].

    Returns
    -------
    control.TransferFunction
        The closed loop.

    Raises
    ------
    ConfigError
        ``gain`` or ``period`` not a positive finite number, or ``delay`` not an integer >= 0.
    """
    return ct.feedback(error_loop(gain, period, delay), 1)


def spectral_radius(gain: float, period: float, delay: int = 0) -> float:
    """Largest pole magnitude of the sampled closed loop (python-control); < 1 is stable.

    Parameters
    ----------
    gain : float
        Error gain K > 0 [1/s].
    period : float
        Sampling period h > 0 [s].
    delay : int
        Control delay n >= 0 [samples].

    Returns
    -------
    float
        Spectral radius [-].

    Raises
    ------
    ConfigError
        ``gain`` or ``period`` not a positive finite number, or ``delay`` not an integer >= 0.
    """
    return float(np.max(np.abs(error_closed_loop(gain, period, delay).poles())))


def control_limit(gain: float, period: float, delay: int = 0) -> float:
    """``K h`` limit from python-control: where the closed loop's largest pole reaches the unit circle.

    (The gain margin of ``L(z)`` cannot be used for ``n = 0``: its phase reaches -180 deg only
    at the Nyquist frequency, where python-control reports an infinite margin.)

    Parameters
    ----------
    gain : float
        Error gain K > 0 [1/s].
    period : float
        Sampling period h > 0 [s].
    delay : int
        Control delay n >= 0 [samples].

    Returns
    -------
    float
        The limit of ``K h`` [-] (independent of ``gain``, which is only checked).

    Raises
    ------
    ConfigError
        ``gain`` or ``period`` not a positive finite number, or ``delay`` not an integer >= 0.
    """
    _check(gain, period, delay)
    return float(brentq(lambda x: spectral_radius(x / period, period, delay) - 1.0, 1e-6, 2.5, xtol=1e-14))


def delay_margin(gain: float, period: float | None = None) -> float:
    """Delay margin [s] of the deviation loop: phase margin / crossover frequency.

    ``period`` None: the continuous loop, ``pi / (2 K)``. Otherwise the sampled loop with
    zero-order hold, whose own half-sample lag already uses part of the margin.

    Parameters
    ----------
    gain : float
        Error gain K > 0 [1/s].
    period : float or None
        Sampling period h > 0 [s]; None: the continuous loop.

    Returns
    -------
    float
        Delay margin [s].
    """
    with warnings.catch_warnings(), np.errstate(divide="ignore", invalid="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)     # K/s evaluated at s = 0 while searching
        gm, pm, sm, wpc, wgc, wms = ct.stability_margins(error_loop(gain, period, 0))
    return float(np.deg2rad(pm) / wgc)


def max_stable_delay(gain: float, period: float) -> int:
    """Largest delay in samples for which the sampled loop is stable (-1: unstable without delay).

    Parameters
    ----------
    gain : float
        Error gain K > 0 [1/s].
    period : float
        Sampling period h > 0 [s].

    Returns
    -------
    int
        The delay [samples] (the search stops after 10,001).

    Raises
    ------
    ConfigError
        ``gain`` or ``period`` not a positive finite number.
    """
    _check(gain, period)
    n = -1
    while gain * period < sampled_limit(n + 1):
        n += 1
        if n > 10_000:
            break
    return n


def step_responses(gain: float, period: float, delays: Sequence[int] = (0, 1, 2), duration: float | None = None) -> dict:
    """Step responses of the deviation loop: continuous and sampled with each delay.

    Parameters
    ----------
    gain : float
        Error gain K > 0 [1/s].
    period : float
        Sampling period h > 0 [s].
    delays : sequence of int
        Control delays [samples], one sampled response each.
    duration : float or None
        Time span [s] (None: ``5 / gain``).

    Returns
    -------
    dict
        ``label -> (t, y)`` arrays, ``y`` the response of ``e`` to a unit step of its reference.
    """
    duration = duration or 5.0 / gain
    out = {"continuous": ct.step_response(error_closed_loop(gain), T=np.linspace(0, duration, 400))}
    for n in delays:
        out[f"ZOH h = {period:.3g} s, delay {n}"] = ct.step_response(
            error_closed_loop(gain, period, n), T=np.arange(0, duration + period / 2, period))
    return {k: (np.asarray(r.time), np.asarray(r.outputs).ravel()) for k, r in out.items()}


def grows(ctrl: CoordinatingController, q0: ArrayLike, period: float, delay: int = 0, samples: int = 600,
          factor: float = 10.0) -> bool:
    """Whether ``max|e|`` of a sampled run exceeds ``factor`` times its start value within ``samples``.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its gain K [1/s]).
    q0 : array_like, shape (m,)
        Start, with a nonzero deviation from the curve [rad].
    period : float
        Sampling period h [s].
    delay : int
        Control delay [samples].
    samples : int
        Samples simulated.
    factor : float
        Growth of ``max|e|`` [-] counted as divergence.

    Returns
    -------
    bool
        True if the run diverged.

    Raises
    ------
    ConfigError
        ``q0`` lies on the curve (zero deviation).
    """
    from coordarm.simulation.sampled import simulate_sampled

    e0 = float(np.max(np.abs(ctrl.evaluate(q0, 0.0)["e"])))
    if not e0 > 0:
        raise ConfigError("q0: needs a nonzero deviation from the curve to see it grow or decay")
    run = simulate_sampled(ctrl, q0, samples * period, period, delay, diverge_at=factor * e0)
    return run.info["stopped"] == "diverged"


def simulated_limit(ctrl: CoordinatingController, q0: ArrayLike, delay: int = 0, rel_tol: float = 1e-3,
                    samples: int = 600) -> float:
    """``K h`` at which the simulated sampled-data loop starts to diverge (bisection on ``h``).

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller; use a curve and speed that leave the deviations unforced (e.g. a static
        curve, ``v* = 0``) so that growth is the loop's own.
    q0 : (m,) array_like
        Start with a small deviation from the curve [rad].
    delay : int
        Control delay [samples].
    rel_tol : float
        Relative width of the final bracket.
    samples : int
        Samples simulated per trial.

    Returns
    -------
    float
        ``K h`` [-] at the middle of the final bracket.

    Raises
    ------
    ConfigError
        The limit is not within 0.5 to 1.5 times :func:`sampled_limit`.
    """
    K, guess = ctrl.gain, sampled_limit(delay)
    lo, hi = 0.5 * guess / K, 1.5 * guess / K
    if grows(ctrl, q0, lo, delay, samples) or not grows(ctrl, q0, hi, delay, samples):
        raise ConfigError(f"the simulated limit is not within [0.5, 1.5] x the predicted {guess:.4g}")
    while hi - lo > rel_tol * lo:
        mid = 0.5 * (lo + hi)
        if grows(ctrl, q0, mid, delay, samples):
            hi = mid
        else:
            lo = mid
    return K * 0.5 * (lo + hi)
