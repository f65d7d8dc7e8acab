"""Orthonormality check of curve descriptions: rotations pass, scaled or mirrored ones are named."""
import warnings

import casadi as ca
import pytest

from coordarm.analysis.orthonormal import OrthonormalityWarning, check_orthonormal
from coordarm.symbolic import Arc, Circle, ConfigError, Line


@pytest.mark.parametrize("curve", [Line(angle=0.3), Line(point=(0.1, lambda t: 0.2 * t), angle=lambda t: ca.sin(t)),
                                   Circle((0.0, 2.0), 2.0), Circle((1.0, -0.5), lambda t: 1.5 + 0.1 * t),
                                   Arc(angle=lambda t: 0.4 * ca.sin(t), radius=lambda t: 2 + 0.3 * ca.sin(t))],
                         ids=["line", "moving-line", "circle", "growing-circle", "breathing-arc"])
def test_shipped_curves_are_orthonormalised(curve):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = check_orthonormal(curve, times=[0.0, 1.3, 4.0])
    assert res.ok and res.worst_deviation < 1e-12 and res.off_curve < 1e-12 and res.points == 192
    assert "is orthonormalised" in res.message()


class ScaledLine(Line):
    """phi scaled by 2: still zero on the line, but not a signed distance."""

    def phi(self, y, t):
        return 2 * super().phi(y, t)


class MirroredCircle(Circle):
    """psi running clockwise while phi is positive inside: a reflection, not a rotation."""

    def psi(self, y, t):
        return -super().psi(y, t)


def test_scaled_phi_is_flagged_with_a_warning_naming_the_point():
    with pytest.warns(OrthonormalityWarning, match=r"not orthonormalised: .* at y = \(.*\) m, t = 0.5 s, deviates"):
        res = check_orthonormal(ScaledLine(angle=0.2), times=[0.5])
    assert not res.ok and res.worst_deviation == pytest.approx(3.0)        # |grad phi|^2 - 1
    assert res.worst_time == 0.5 and res.worst_point.shape == (2,)


def test_mirrored_description_is_flagged_by_its_determinant():
    res = check_orthonormal(MirroredCircle((0.0, 1.0), 1.0), warn=False)
    assert not res.ok and res.worst_deviation == pytest.approx(2.0)          # det = -1


def test_non_curve_is_refused():
    with pytest.raises(ConfigError, match="curve: expected a Curve"):
        check_orthonormal(lambda y, t: 0.0)
