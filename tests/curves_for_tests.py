"""Curves with moving parameters shared by the law tests (interpreted and compiled)."""
import casadi as ca

from coordarm.symbolic import Arc, Circle, Line


def moving_curve(kind: str):
    """A line, circle or arc (``kind``) whose parameters all move with time."""
    if kind == "line":
        return Line(point=(lambda t: 0.02 * ca.sin(t), 0.01), angle=lambda t: 0.6 * ca.sin(0.2 * t))
    if kind == "circle":
        return Circle(center=(lambda t: 0.1 * ca.sin(0.5 * t), 2.0), radius=lambda t: 2.0 + 0.1 * ca.cos(t))
    return Arc(angle=lambda t: 0.3 * ca.sin(0.4 * t), radius=lambda t: 1.5 + 0.2 * ca.sin(t))
