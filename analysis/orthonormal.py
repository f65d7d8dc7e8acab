"""The orthonormality check of a curve description (it lives in :mod:`coordarm.symbolic.orthonormal`,
where the controller uses it on user-defined curves); kept here for the analysis API."""
from coordarm.symbolic.orthonormal import OrthonormalityCheck, OrthonormalityWarning, check_orthonormal

__all__ = ["OrthonormalityCheck", "OrthonormalityWarning", "check_orthonormal"]
