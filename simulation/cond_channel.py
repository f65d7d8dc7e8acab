"""The rate and the meaning of ``/margins/cond``: the 1-norm condition number (O(m) estimate above 256 joints) by default, the exact 2-norm value on request."""
from __future__ import annotations

#: Default rate of ``/margins/cond`` [Hz].
COND_RATE = 5.0
#: Above this many links the exact ``/margins/cond`` is off unless a rate is given (one SVD of a
#: 4096 x 4096 decoupling matrix takes about a minute; at 16384 links the matrix is 2 GiB).
COND_LINK_LIMIT = 1024
#: What the ``cond`` field holds, by ``cond_exact`` (the ``run`` metadata's ``cond`` entry).
COND_KINDS = {False: "1-norm (exact up to 256 joints, above: an O(m) lower-bound estimate)", True: "2-norm exact"}


def default_cond_rate(links: int, exact: bool = True) -> float:
    """Default rate of ``/margins/cond`` [Hz].

    The estimate (``exact=False``, the default of a run) costs O(m) per sample like a step of the
    law: :data:`COND_RATE` at every size. The exact value is an SVD of the m x m decoupling matrix,
    O(m^3): :data:`COND_RATE` up to 64 links, then ``* (64/m)^2``, and 0 (channel off) above
    :data:`COND_LINK_LIMIT` links, which keeps its share of a run's time about what it is at 64 links.

    Parameters
    ----------
    links : int
        Number of links m (> 0).
    exact : bool
        The rate of the exact 2-norm condition number (True) or of the O(m) estimate (False).

    Returns
    -------
    float
        The rate [Hz]; for the exact value 0 above :data:`COND_LINK_LIMIT` links.
    """
    if not exact:
        return COND_RATE
    if links > COND_LINK_LIMIT:
        return 0.0
    return COND_RATE * min(1.0, (64.0 / links) ** 2)
