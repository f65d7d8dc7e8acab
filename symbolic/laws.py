"""Names of the forms of the control law (dependency-free, so the command line can offer them at once)."""
from enum import StrEnum


class Law(StrEnum):
    """Form of the coordinating law; a member equals (and prints as) its string value.

    ``STRUCTURED``: the O(m) recursion; ``DENSE``: the dense decoupling matrix and a QR solve.
    """

    STRUCTURED = "structured"
    DENSE = "dense"


#: The law names as plain strings, in order (argparse choices and error messages).
LAWS = tuple(law.value for law in Law)
