"""Pool (Append/Consume on an atomic counter) and PingPong: clkernels/include/pool.h, ugpcl/buffers.py."""

from __future__ import annotations

import numpy as np
import pytest

from ugpcl.buffers import PingPong, Pool
from ugpcl.runtime import round_up

LOCAL = 64


def append_multiples(rt, pool: Pool, n: int, every: int) -> None:
    rt.program("pool").kernel("AppendMultiples")(
        (round_up(n, LOCAL),),
        (LOCAL,),
        pool.counter.data,
        pool.items.data,
        np.int32(pool.capacity),
        np.int32(n),
        np.int32(every),
    )


def consume_into(rt, pool: Pool, n: int) -> np.ndarray:
    out = rt.zeros(max(n, 1), np.int32)
    rt.program("pool").kernel("ConsumeInto")(
        (round_up(n, LOCAL),), (LOCAL,), pool.counter.data, pool.items.data, out.data, np.int32(n)
    )
    return out.get()[:n]


@pytest.mark.parametrize("n, every", [(1, 1), (63, 1), (64, 1), (65, 1), (10_000, 3), (100_003, 7)])
def test_append_from_many_work_items_gives_exactly_the_expected_set(runtime, n, every):
    pool = Pool(runtime, capacity=n)
    append_multiples(runtime, pool, n, every)
    expected = np.arange(0, n, every)
    assert pool.count() == len(expected)
    assert pool.refused() == 0
    items = pool.read()
    assert len(np.unique(items)) == len(items), "an index was appended twice (two work-items got one slot)"
    np.testing.assert_array_equal(np.sort(items), expected)


def test_append_past_capacity_is_refused_and_counted(runtime):
    pool = Pool(runtime, capacity=1000)
    append_multiples(runtime, pool, 5000, 1)
    assert pool.count() == 1000  # clamped, never above capacity
    assert pool.refused() == 4000
    items = pool.read()
    assert len(np.unique(items)) == 1000 and items.min() >= 0 and items.max() < 5000


def test_consume_exactly_count_items_empties_the_pool(runtime):
    pool = Pool(runtime, capacity=5000)
    pool.fill(np.arange(5000, 10000))
    taken = consume_into(runtime, pool, pool.count())  # the host dispatches exactly count() consumers
    assert pool.count() == 0
    np.testing.assert_array_equal(np.sort(taken), np.arange(5000, 10000))


def test_consume_past_empty_never_underflows(runtime):
    pool = Pool(runtime, capacity=100)
    pool.fill(np.arange(10))
    taken = consume_into(runtime, pool, 300)  # more consumers than items: the kernel's safety net
    assert pool.count() == 0, "the counter went negative or lost an undo"
    assert (taken == -1).sum() == 290
    np.testing.assert_array_equal(np.sort(taken[taken >= 0]), np.arange(10))


def test_append_after_consume_keeps_the_counter_consistent(runtime):
    pool = Pool(runtime, capacity=256)
    pool.fill(np.arange(200))
    consume_into(runtime, pool, 150)
    append_multiples(runtime, pool, 256, 1)  # 50 left + 206 free slots; 50 of the 256 appends are refused
    assert pool.count() == 256
    assert pool.refused() == 50


def test_host_side_counter_checks(runtime):
    pool = Pool(runtime, capacity=8, name="attractions")
    with pytest.raises(ValueError, match="attractions: count must be in \\[0, 8\\], got 9"):
        pool.set_count(9)
    with pytest.raises(ValueError, match="do not fit capacity 8"):
        pool.fill(np.arange(9))
    with pytest.raises(ValueError, match="capacity must be >= 1"):
        Pool(runtime, capacity=0)


def test_ping_pong_swaps_read_and_write(runtime):
    pair = PingPong.zeros(runtime, 4, np.float32)
    first_read, first_write = pair.read, pair.write
    pair.swap()
    assert pair.read is first_write and pair.write is first_read


@pytest.mark.oclgrind
def test_pool_kernels_on_oclgrind(oclgrind):
    pool = Pool(oclgrind, capacity=40)
    append_multiples(oclgrind, pool, 100, 2)  # 50 appends into 40 slots: 10 refused
    assert pool.count() == 40 and pool.refused() == 10
    taken = consume_into(oclgrind, pool, 45)
    assert pool.count() == 0 and (taken == -1).sum() == 5
