"""SHA-256 without OpenSSL: :func:`sha256` is :func:`hashlib.sha256` by CPython's built-in implementation.

:mod:`hashlib` loads OpenSSL's ``libcrypto`` (``_hashlib``, about 3 ms) when it is first imported,
while what a run hashes (the cache key's text, a 40 kB library, a few small metadata texts and
arrays) takes well under a millisecond either way. The built-in module gives the same digests with
the same interface (``update``, ``copy``, ``digest``, ``hexdigest``); where the interpreter has none
(built without it) :mod:`hashlib`'s is used.
"""
from __future__ import annotations

try:
    from _sha256 import sha256              # CPython up to 3.11
except ImportError:                         # pragma: no cover (other interpreters)
    try:
        from _sha2 import sha256            # CPython 3.12 and later
    except ImportError:
        from hashlib import sha256

__all__ = ["sha256"]
