"""Minimal 3-D curves for the spatial law's tests, following the SpatialCurve interface of SPATIAL.md
(``psi``, ``Phi``, ``frame``, ``sample``) until ``symbolic/curves3d.py`` lands. Test helpers only."""
from __future__ import annotations

import casadi as ca
import numpy as np


def _const(v):
    return v if callable(v) else (lambda t, v=float(v): v + 0 * t)


def _rodrigues(axis, angle):
    """Rotation matrix about the unit ``axis`` (numpy) by a CasADi ``angle``."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = ca.DM([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return ca.DM.eye(3) + ca.sin(angle) * K + (1 - ca.cos(angle)) * ca.mtimes(K, K)


class Line3D:
    """Line through ``point(t)`` along ``direction`` with ``n_1 = normal`` (orthogonalised), ``n_2 = t x n_1``,
    optionally turned rigidly by ``rotation = (axis, angle(t))`` about ``point``."""

    def __init__(self, point, direction, normal, rotation=None):
        self.point = [_const(c) for c in point]
        d = np.asarray(direction, float)
        d /= np.linalg.norm(d)
        n = np.asarray(normal, float) - np.dot(normal, d) * d
        n /= np.linalg.norm(n)
        self.base_frame = (d, n, np.cross(d, n))
        self.rotation = None if rotation is None else (rotation[0], _const(rotation[1]))

    def _p_frame(self, t):
        p = ca.vertcat(*[c(t) for c in self.point])
        vecs = [ca.DM(v) for v in self.base_frame]
        if self.rotation is not None:
            Rm = _rodrigues(self.rotation[0], self.rotation[1](t))
            vecs = [ca.mtimes(Rm, v) for v in vecs]
        return p, vecs

    def psi(self, y, t):
        p, (tg, _, _) = self._p_frame(t)
        return ca.dot(tg, y - p)

    def Phi(self, y, t):
        p, (_, n1, n2) = self._p_frame(t)
        return ca.vertcat(ca.dot(n1, y - p), ca.dot(n2, y - p))

    def frame(self, y, t):
        _, vecs = self._p_frame(t)
        return tuple(v + 0 * y[0] for v in vecs)

    def sample(self, t, n=200, extent=None):
        p, vecs = self._p_frame(t)
        p, tg = np.asarray(ca.DM(ca.evalf(p))).ravel(), np.asarray(ca.DM(ca.evalf(vecs[0]))).ravel()
        s = np.linspace(-(extent or 10.0), extent or 10.0, n)
        return p + s[:, None] * tg


class Circle3D:
    """Circle of ``radius`` about ``centre`` in the plane of unit ``normal`` w, counter-clockwise about w;
    arc length from the direction ``ref`` (in the plane); ``n_1 = -r/|r|`` (inwards), ``n_2 = w``."""

    def __init__(self, centre, radius, normal, ref):
        w = np.asarray(normal, float)
        self.w = w / np.linalg.norm(w)
        e0 = np.asarray(ref, float) - np.dot(ref, self.w) * self.w
        self.e0 = e0 / np.linalg.norm(e0)
        self.e1 = np.cross(self.w, self.e0)
        self.c, self.R = np.asarray(centre, float), float(radius)

    def _r(self, y):
        v = y - ca.DM(self.c)
        return v - ca.dot(v, ca.DM(self.w)) * ca.DM(self.w), ca.dot(v, ca.DM(self.w))

    def psi(self, y, t):
        r, _ = self._r(y)
        return self.R * ca.atan2(ca.dot(ca.DM(self.e1), r), ca.dot(ca.DM(self.e0), r)) + 0 * t

    def Phi(self, y, t):
        r, h = self._r(y)
        return ca.vertcat(self.R - ca.norm_2(r), h) + 0 * t

    def frame(self, y, t):
        r, _ = self._r(y)
        rh = r / ca.norm_2(r)
        w = ca.DM(self.w) + 0 * t
        return ca.cross(w, rh), -rh, w

    def sample(self, t, n=200, extent=None):
        a = np.linspace(0, 2 * np.pi, n)
        return self.c + self.R * (np.cos(a)[:, None] * self.e0 + np.sin(a)[:, None] * self.e1)
