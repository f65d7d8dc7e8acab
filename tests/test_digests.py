"""coordarm.symbolic.digests.sha256 against hashlib's (OpenSSL's) SHA-256: the same digests, one shot and
fed in pieces, through copies; and a run does not load OpenSSL for it."""
import hashlib
import random

import pytest

from coordarm.symbolic.digests import sha256


@pytest.mark.parametrize("size", [0, 1, 55, 56, 63, 64, 65, 1000, 41298, 1 << 20])
def test_the_digest_of_any_length_is_hashlibs(size):
    data = random.Random(size).randbytes(size)
    assert sha256(data).hexdigest() == hashlib.sha256(data).hexdigest()
    assert sha256(data).digest() == hashlib.sha256(data).digest()


def test_pieces_and_copies_give_hashlibs_digests():
    rng = random.Random(7)
    ours, theirs = sha256(), hashlib.sha256()
    for _ in range(50):
        piece = rng.randbytes(rng.randrange(0, 300))
        ours.update(piece)
        theirs.update(piece)
        fork, their_fork = ours.copy(), theirs.copy()
        fork.update(b"\0")
        their_fork.update(b"\0")
        assert fork.hexdigest() == their_fork.hexdigest()
        assert ours.hexdigest() == theirs.hexdigest()          # the copy left the original as it was
    assert (ours.name, ours.digest_size, ours.block_size) == (theirs.name, theirs.digest_size, theirs.block_size)
