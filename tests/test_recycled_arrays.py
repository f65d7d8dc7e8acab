"""RecycledArrays hands an array out again only when no view of it is alive (the log's sample records)."""
import numpy as np

from coordarm.simulation.recycled_arrays import RecycledArrays


def _address(view) -> int:
    return view.__array_interface__["data"][0]


def test_an_array_comes_back_only_once_every_view_of_it_is_gone():
    pool = RecycledArrays(np.float64)
    a = pool.take(10, spare=5)
    first = _address(a)
    chunk = a[:4].view(np.uint8)            # what a queued chunk holds
    del a
    b = pool.take(8)
    assert _address(b) != first and not np.shares_memory(b, chunk)   # the chunk still refers to it
    del chunk
    c = pool.take(15)
    assert _address(c) == first and len(c) == 15     # free again, and large enough (10 + 5 spare)
    d = pool.take(16)
    assert len(d) == 16 and not np.shares_memory(d, c) and not np.shares_memory(d, b)


def test_at_most_keep_arrays_are_kept_the_smallest_let_go_first():
    pool = RecycledArrays(np.int64, keep=2)
    held = [pool.take(n) for n in (3, 30, 300)]       # all alive: three new arrays, the smallest let go
    assert sorted(len(x) for x in pool._arrays) == [30, 300]
    big = _address(held[2])
    del held
    again = _address(pool.take(31))       # (each view dropped at once)
    assert again == big and _address(pool.take(31)) == big
