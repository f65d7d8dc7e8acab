"""Names of the forms of the control law (dependency-free, so the command line can offer them at once)."""

#: ``"structured"``: the O(m) recursion; ``"dense"``: the dense decoupling matrix and a QR solve.
LAWS = ("structured", "dense")
