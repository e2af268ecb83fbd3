"""Uniform grid (clkernels/grid.cl, ugpcl/grid.py): the counting sort's keys and cell ranges against numpy, the same
arrays on every build, exact neighbour sets and the neighbour loop's visiting order."""

from __future__ import annotations

import numpy as np
import pytest

from ugpcl.grid import UniformGrid
from ugpcl.runtime import round_up


def count_neighbours(rt, grid: UniformGrid, items, n: int, stride: int, offset: int, radius: float) -> np.ndarray:
    count = rt.zeros(max(n, 1), np.int32)
    grid.program.kernel("GridCountNeighbours")(
        (round_up(max(n, 1), 64),),
        None,
        items.data,
        np.int32(stride),
        np.int32(offset),
        np.int32(n),
        np.float32(radius),
        *grid.geometry_args(),
        *grid.search_args(),
        count.data,
    )
    return count.get()[:n]


def brute_force(points: np.ndarray, radius: float) -> np.ndarray:
    d2 = ((points[:, None, :].astype(np.float64) - points[None, :, :]) ** 2).sum(-1)
    return (d2 <= radius * radius).sum(axis=1)


@pytest.mark.parametrize("n", [1, 2, 63, 64, 65, 1000, 3001])
def test_keys_are_sorted_and_ranges_cover_every_item(runtime, n, seed):
    points = np.random.default_rng(seed).uniform(-1, 1, (n, 4)).astype(np.float32)
    items = runtime.to_device(points)
    grid = UniformGrid.covering(runtime, n, (-1, -1, -1), (1, 1, 1), 0.25)
    grid.build(items, n, stride=4)
    keys = grid.sorted_keys()
    assert (np.diff(keys.astype(np.float64)) > 0).all(), "keys not strictly ascending"
    np.testing.assert_array_equal(np.sort(keys & 0xFFFFFFFF), np.arange(n))  # every item exactly once
    cells = (keys >> 32).astype(np.int64)
    start, end = grid.cell_start.get(), grid.cell_end.get()
    assert (end - start).sum() == n
    for c in np.unique(cells):
        assert (cells[start[c] : end[c]] == c).all()


def reference_sort(points: np.ndarray, grid: UniformGrid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """numpy's sorted keys, cell_start and cell_end for items at ``points`` (n, 3): cells clamped into the grid."""
    dims = np.array(grid.dims)
    coord = np.floor((points - np.array(grid.origin)) / grid.cell_size).astype(np.int64)
    coord = np.clip(coord, 0, dims - 1)
    cells = (coord[:, 2] * dims[1] + coord[:, 1]) * dims[0] + coord[:, 0]
    keys = np.sort((cells.astype(np.uint64) << np.uint64(32)) | np.arange(len(points), dtype=np.uint64))
    end = np.cumsum(np.bincount(cells, minlength=grid.num_cells))
    return keys, end - np.bincount(cells, minlength=grid.num_cells), end


def cell_centred_points(rng, n: int, lower, cell_size: float, cells_per_axis, outside: int = 0) -> np.ndarray:
    """n points within 0.3 cells of random cell centres (no float rounding at a cell border can move one), the first
    ``outside`` of them pushed up to 3 cells beyond the grid on every axis."""
    lower = np.array(lower, float)
    picks = rng.integers(0, cells_per_axis, (n, len(lower)))
    shift = np.zeros((n, len(lower)), np.int64)
    shift[:outside] = rng.choice([-3, -2, 2, 3], (outside, len(lower)))  # 2, 3 past the end or before the start
    shift[:outside] += np.where(shift[:outside] > 0, np.array(cells_per_axis) - 1, 0)
    picks[:outside] = shift[:outside]
    return lower + (picks + 0.5 + rng.uniform(-0.3, 0.3, (n, len(lower)))) * cell_size


def built(runtime, points: np.ndarray, grid: UniformGrid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    data = np.zeros((len(points), 4), np.float32)
    data[:, : points.shape[1]] = points
    grid.build(runtime.to_device(data), len(points), stride=4)
    return grid.sorted_keys(), grid.cell_start.get(), grid.cell_end.get()


@pytest.mark.parametrize(
    "n, lower, cells, outside",
    [
        (3001, (-1, -1, -1), (8, 8, 8), 100),  # 3D, N not a multiple of the work-group size, some outside
        (1000, (0, 0), (2100, 2100), 50),  # 2D, 4.4 M cells: three scan levels; almost every cell empty
        (65, (0, 0, 0), (1, 1, 1), 0),  # all in one cell
        (2000, (0, 0), (2, 2), 0),  # 500 per cell: long runs to order
    ],
)
def test_counting_sort_equals_numpy(runtime, seed, n, lower, cells, outside):
    rng = np.random.default_rng(seed)
    points = cell_centred_points(rng, n, lower, 0.5, cells, outside)
    upper = np.array(lower) + 0.5 * np.array(cells)
    grid = UniformGrid.covering(runtime, n, lower, upper, 0.5)
    assert grid.dims == (*cells, 1, 1)[:3]
    keys, start, end = built(runtime, points, grid)
    ref_keys, ref_start, ref_end = reference_sort(np.column_stack([points, np.zeros((n, 3 - len(lower)))]), grid)
    np.testing.assert_array_equal(keys, ref_keys)
    np.testing.assert_array_equal(start, ref_start)  # empty cells: start == end == the items of the cells before
    np.testing.assert_array_equal(end, ref_end)


def test_two_builds_give_the_same_arrays(runtime, seed):
    """The scatter's atomic order varies; the arrays must not. Few cells, many items each: many ties in arrival."""
    rng = np.random.default_rng(seed)
    points = cell_centred_points(rng, 20000, (0, 0), 0.5, (3, 3))
    grid = UniformGrid.covering(runtime, len(points), (0, 0), (1.5, 1.5), 0.5)
    first = built(runtime, points, grid)
    for _ in range(3):
        for a, b in zip(first, built(runtime, points, grid), strict=True):
            np.testing.assert_array_equal(a, b)


def test_sort_orders_keys_written_in_any_order_and_puts_empty_keys_last(runtime, seed):
    """``sort`` on keys a chapter's hash kernel wrote (space colonization: inactive nodes get GRID_EMPTY_KEY), here
    shuffled, so the scatter's arrival order is not the item order and only the last pass can restore it: the live
    keys in order, then the empty ones; no cell counts them."""
    rng = np.random.default_rng(seed)
    n, grid = 1500, UniformGrid(runtime, 1500, (0, 0, 0), 1.0, (7, 5, 3))
    cells = rng.integers(0, grid.num_cells, n).astype(np.uint64)
    keys = (cells << np.uint64(32)) | np.arange(n, dtype=np.uint64)
    live = rng.uniform(size=n) < 0.3
    keys[~live] = np.uint64(0xFFFFFFFFFFFFFFFF)
    grid.hash_keys.set(keys[rng.permutation(n)])
    grid.sort(n)
    np.testing.assert_array_equal(grid.sorted_keys(), np.sort(keys))
    end = np.cumsum(np.bincount(cells[live].astype(np.int64), minlength=grid.num_cells))
    np.testing.assert_array_equal(grid.cell_end.get(), end)
    np.testing.assert_array_equal(
        grid.cell_start.get(), end - np.bincount(cells[live].astype(np.int64), minlength=grid.num_cells)
    )


@pytest.mark.parametrize("n, record_floats", [(1, 4), (63, 8), (64, 4), (65, 8), (3001, 12)])
def test_copy_in_cell_order_puts_each_record_at_its_key(runtime, seed, n, record_floats):
    """Record k of the copy is the record of the item of sorted key k, whole (every float, not only the position)."""
    rng = np.random.default_rng(seed)
    data = rng.uniform(-1, 1, (n, record_floats)).astype(np.float32)
    items = runtime.to_device(data)
    grid = UniformGrid.covering(runtime, n, (-1, -1, -1), (1, 1, 1), 0.25)
    grid.build(items, n, stride=record_floats, offset=record_floats - 4)  # the position at the record's end
    sorted_items = runtime.empty((n, record_floats), np.float32)
    grid.copy_in_cell_order(items, sorted_items, 4 * record_floats)
    order = (grid.sorted_keys() & 0xFFFFFFFF).astype(np.int64)
    np.testing.assert_array_equal(sorted_items.get(), data[order])


def test_copy_in_cell_order_leaves_the_slots_of_empty_keys(runtime, seed):
    """After ``sort`` with keys left out (GRID_EMPTY_KEY), their slots at the end are not written."""
    rng = np.random.default_rng(seed)
    n, grid = 300, UniformGrid(runtime, 300, (0, 0, 0), 1.0, (4, 4, 1))
    keys = (rng.integers(0, grid.num_cells, n).astype(np.uint64) << np.uint64(32)) | np.arange(n, dtype=np.uint64)
    keys[::3] = np.uint64(0xFFFFFFFFFFFFFFFF)
    grid.hash_keys.set(keys)
    grid.sort(n)
    data = rng.uniform(size=(n, 4)).astype(np.float32)
    sorted_items = runtime.to_device(np.full((n, 4), -7.0, np.float32))
    grid.copy_in_cell_order(runtime.to_device(data), sorted_items, 16)
    live = np.sort(keys[keys != np.uint64(0xFFFFFFFFFFFFFFFF)])
    copied = sorted_items.get()
    np.testing.assert_array_equal(copied[: len(live)], data[(live & 0xFFFFFFFF).astype(np.int64)])
    assert (copied[len(live) :] == -7.0).all()
    with pytest.raises(ValueError, match="multiple of 16, got 12"):
        grid.copy_in_cell_order(runtime.to_device(data), sorted_items, 12)


def test_no_items_leave_every_cell_empty(runtime):
    grid = UniformGrid(runtime, 8, (0, 0, 0), 1.0, (30, 30, 1))
    grid.build(runtime.zeros(32, np.float32), 8, stride=4)
    grid.build(runtime.zeros(32, np.float32), 0, stride=4)  # after a build with items: nothing left over
    assert len(grid.sorted_keys()) == 0
    assert not grid.cell_start.get().any() and not grid.cell_end.get().any()


@pytest.mark.parametrize("dims3", [True, False])
def test_neighbour_counts_equal_brute_force(runtime, dims3, seed):
    rng = np.random.default_rng(seed)
    n, radius = 2500, 0.3
    points = rng.uniform(-2, 2, (n, 3))
    points[:50] *= 3  # some items outside the grid: clamped into the border cells, still found
    if not dims3:
        points[:, 2] = 0
    # an AoS layout: (radius, x, y, z, pad) per item -> stride 5, offset 1
    data = np.zeros((n, 5), np.float32)
    data[:, 1:4] = points
    items = runtime.to_device(data)
    lower, upper = ((-2, -2, -2), (2, 2, 2)) if dims3 else ((-2, -2), (2, 2))
    grid = UniformGrid.covering(runtime, n, lower, upper, radius)
    grid.build(items, n, stride=5, offset=1)
    counts = count_neighbours(runtime, grid, items, n, 5, 1, radius)
    np.testing.assert_array_equal(counts, brute_force(data[:, 1:4] if dims3 else data[:, 1:3], radius))


def list_neighbours(rt, grid: UniformGrid, items, n: int, stride: int, max_found: int) -> np.ndarray:
    found = rt.empty((n, max_found), np.int32)
    grid.program.kernel("GridListNeighbours").over(
        n,
        64,
        items.data,
        np.int32(stride),
        np.int32(0),
        np.int32(n),
        *grid.geometry_args(),
        *grid.search_args(),
        np.int32(max_found),
        found,
    )
    return found.get()


def item_cells(grid: UniformGrid, n: int) -> np.ndarray:
    """Each item's (clamped) cell, read from the sorted keys."""
    keys = grid.sorted_keys()
    cells = np.empty(n, np.int64)
    cells[(keys & 0xFFFFFFFF).astype(np.int64)] = (keys >> 32).astype(np.int64)
    return cells


def visiting_order_reference(cells: np.ndarray, dims: tuple, i: int) -> list[int]:
    """grid.h's promise, from the item cells alone: the 27 cells around item i's cell (9 when dims z == 1) that lie
    inside the grid, in increasing id; the items of each in increasing index."""
    nx, ny, nz = dims
    home = cells[i]
    hx, hy, hz = home % nx, home // nx % ny, home // (nx * ny)
    order = []
    for dz in (-1, 0, 1) if nz > 1 else (0,):
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                x, y, z = hx + dx, hy + dy, hz + dz
                if 0 <= x < nx and 0 <= y < ny and 0 <= z < nz:
                    order += np.flatnonzero(cells == (z * ny + y) * nx + x).tolist()
    return order


@pytest.mark.parametrize(
    "lower, upper, cell_size",
    [
        ((-1, -1, -1), (1, 1, 1), 0.5),  # 4 x 4 x 4: interior, faces, edges and corners
        ((-1, -1), (1, 1), 0.5),  # 2D, dims z = 1: the dz = 0 layer only
        ((0, 0, 0), (1, 0.5, 3), 1.0),  # 1 x 1 x 3: every x and y neighbour is outside
    ],
)
def test_neighbour_loop_visits_the_cells_around_in_increasing_id(runtime, seed, lower, upper, cell_size):
    n = 300
    rng = np.random.default_rng(seed)
    points = np.zeros((n, 4), np.float32)
    points[:, : len(lower)] = rng.uniform(np.array(lower) - 0.2, np.array(upper) + 0.2, (n, len(lower)))  # some outside
    items = runtime.to_device(points)
    grid = UniformGrid.covering(runtime, n, lower, upper, cell_size)
    grid.build(items, n, stride=4)
    cells = item_cells(grid, n)
    found = list_neighbours(runtime, grid, items, n, 4, n + 1)
    for i in range(n):
        expected = visiting_order_reference(cells, grid.dims, i)
        got = found[i][found[i] >= 0].tolist()
        assert got == expected, (
            f"item {i} (cell {cells[i]} of {grid.dims}): visited {got[:12]}..., expected {expected[:12]}..."
        )
        assert (found[i][len(got) :] == -1).all()


def test_build_checks_its_input(runtime):
    grid = UniformGrid(runtime, 10, (0, 0, 0), 1.0, (4, 4, 4))
    with pytest.raises(ValueError, match="n must be in \\[0, 10\\], got 11"):
        grid.build(runtime.zeros(44, np.float32), 11, 4)
    with pytest.raises(ValueError, match="cell_size must be > 0"):
        UniformGrid(runtime, 10, (0, 0, 0), 0.0, (4, 4, 4))


@pytest.mark.oclgrind
def test_grid_kernels_on_oclgrind(oclgrind, seed):
    n = 37
    points = np.random.default_rng(seed).uniform(0, 1, (n, 4)).astype(np.float32)
    items = oclgrind.to_device(points)
    grid = UniformGrid.covering(oclgrind, n, (0, 0, 0), (1, 1, 1), 0.34)
    grid.build(items, n, stride=4)
    counts = count_neighbours(oclgrind, grid, items, n, 4, 0, 0.34)
    np.testing.assert_array_equal(counts, brute_force(points[:, :3], 0.34))
    found, cells = list_neighbours(oclgrind, grid, items, n, 4, n + 1), item_cells(grid, n)
    for i in range(n):
        assert found[i][found[i] >= 0].tolist() == visiting_order_reference(cells, grid.dims, i), i
    sorted_items = oclgrind.empty((n, 4), np.float32)
    grid.copy_in_cell_order(items, sorted_items, 16)
    np.testing.assert_array_equal(sorted_items.get(), points[(grid.sorted_keys() & 0xFFFFFFFF).astype(np.int64)])


@pytest.mark.oclgrind
def test_counting_sort_on_oclgrind(oclgrind, seed):
    """Two scan levels (2500 cells), long runs, items outside, and the empty keys of a chapter's own hash."""
    rng = np.random.default_rng(seed)
    points = cell_centred_points(rng, 300, (0, 0), 0.5, (50, 50), outside=20)
    points[:100] = points[0]  # 100 items in one cell
    grid = UniformGrid.covering(oclgrind, 300, (0, 0), (25, 25), 0.5)
    keys, start, end = built(oclgrind, points, grid)
    ref_keys, ref_start, ref_end = reference_sort(np.column_stack([points, np.zeros(300)]), grid)
    np.testing.assert_array_equal(keys, ref_keys)
    np.testing.assert_array_equal(start, ref_start)
    np.testing.assert_array_equal(end, ref_end)
    keys[::3] = np.uint64(0xFFFFFFFFFFFFFFFF)
    grid.hash_keys.set(keys[rng.permutation(300)])
    grid.sort(300)
    np.testing.assert_array_equal(grid.sorted_keys(), np.sort(keys))
    sorted_items = oclgrind.empty((300, 4), np.float32)  # the empty keys' slots: not read, not written
    data = np.column_stack([points, np.arange(300), np.zeros(300)]).astype(np.float32)
    grid.copy_in_cell_order(oclgrind.to_device(data), sorted_items, 16)
    live = np.sort(keys)[:200]
    np.testing.assert_array_equal(sorted_items.get()[:200], data[(live & 0xFFFFFFFF).astype(np.int64)])
