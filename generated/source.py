"""The generated C of a controller as a value: :class:`Source`, and the code generator's options (both part of
a library's cache key, :func:`coordarm.generated.build.cache_key`), without the code generator's imports."""
from __future__ import annotations

from coordarm.symbolic.records import record

#: Options of CasADi's CodeGenerator (part of the cache key).
CODEGEN_OPTIONS = {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"}


@record(frozen=True)
class Source:
    """Generated C source of one controller.

    Attributes
    ----------
    text : str
        The complete C translation unit.
    form : str
        ``"structured"`` or ``"dense"``.
    m : int
        Number of links.
    """

    text: str
    form: str
    m: int
