"""
A user-defined curve
====================

Any :class:`coordarm.Curve` with ``phi(y, t)`` (signed distance, + to the left), ``psi(y, t)``
(arc length) as CasADi expressions and ``sample(t, n, extent)`` (points, for checks and
figures) drives the law: here a parabola near its vertex, described by its osculating circle.
The zig-zag starts on the tangent, so every deviation ``e^j`` decays like ``exp(-K t)``.
"""
import casadi as ca
import matplotlib.pyplot as plt
import numpy as np

from coordarm import CoordinatingController, Curve, PlanarChain, simulate


class Parabola(Curve):
    """y2 = c y1^2 near its vertex, by its osculating circle of radius 1/(2c) (exact on that circle)."""

    def __init__(self, c):
        self.R = 1 / (2 * c)

    def phi(self, y, t):
        return self.R - ca.sqrt(y[0] ** 2 + (y[1] - self.R) ** 2)

    def psi(self, y, t):
        return self.R * ca.atan2(y[0], self.R - y[1])

    def sample(self, t, n=400, extent=10.0):
        a = np.linspace(-1.0, 1.0, n)
        return np.stack([self.R * np.sin(a), self.R - self.R * np.cos(a)], axis=1)


duration = 3.0   # [s]

chain = PlanarChain(links=16, link_length=0.1)
ctrl = CoordinatingController(chain, Parabola(0.25), gain=2.0, speed=0.1)
run = simulate(ctrl, chain.zigzag(1.2), duration=duration, step=0.01)

# %%
# The largest deviation against the designed decay ``e(0) exp(-K t)``:
emax = np.max(np.abs(run.e), axis=1)
fig, ax = plt.subplots(figsize=(6, 3.2))
ax.semilogy(run.t, emax, label="max |e^j|")
ax.semilogy(run.t, emax[0] * np.exp(-2.0 * run.t), "--", label="e(0) exp(-K t)")
ax.set_xlabel("t [s]")
ax.set_ylabel("[m]")
ax.legend()
fig.tight_layout()
