"""``ugpcl bench space_colonization``: a whole tree grown per cloud size, with the book's all-pairs loops and with the
uniform grid, and the all-pairs loops' pair tests per second (docs/chapters/12-space-colonization.md)."""

from __future__ import annotations

import math
import time

import numpy as np

from ..scenes.space_colonization import Params, Simulation


def sphere_count(side: int) -> int:
    """Attractions of the book's sphere cloud of this side (the jitter never changes the count)."""
    g = (np.arange(side) / (side - 1) - 0.5) ** 2
    return int(((g[:, None, None] + g[None, :, None] + g[None, None, :]) < 0.25).sum())


def side_for(size: int) -> int:
    """The sphere side whose cloud holds the number of attractions nearest to `size` (about pi/6 side^3)."""
    guess = round((6.0 * size / math.pi) ** (1.0 / 3.0))
    return min(range(max(4, guess - 2), guess + 3), key=lambda side: abs(sphere_count(side) - size))


def grow_fully(sim: Simulation, max_steps: int) -> tuple[int, float, int]:
    """Step until nothing can grow any more: no free slot is left, or no node was made for as long as the slowest
    node needs to mature. Returns (steps run, seconds, step of the last growth)."""
    p = sim.params
    patience = math.ceil(1.0 / (sim.default_dt * p.growth_speed * p.mass_min)) + 1
    queue = sim.runtime.queue
    queue.finish()
    start = time.perf_counter()
    while sim.steps < max_steps:
        sim.step()
        if sim.free_slots == 0 or sim.steps - sim.last_growth_step > patience:
            break
    queue.finish()
    return sim.steps, time.perf_counter() - start, sim.last_growth_step


PAIR_FLOPS = 9
"""One attraction-node pair of Search or Remove (all pairs): the difference (3), its length (dot 5, sqrt 1). Flop
convention of the benches: an FMA is 2, sqrt and a division 1 each, compares 0."""


def all_pairs_tests(runtime, side: int) -> int:
    """Pairs that the all-pairs Search and Remove test over a whole growth (grow_fully from the reset): per step
    that runs them, active attractions x live nodes each (Remove stops at the first node within the kill distance:
    counted as the whole loop, exact for the attractions that stay). Counted in an untimed replay of the grid
    variant (the same tree), reading the attractions before each step."""
    sim = Simulation(runtime, Params(side=side, search="grid"), seed=0)
    book_step, tests = sim.book_step, 0

    def counted(dt: float) -> None:
        nonlocal tests
        if sim.free_slots > 0:  # Search .. Remove run only then
            tests += 2 * int(np.count_nonzero(sim.read_attractions()["active"])) * sim.live_nodes
        book_step(dt)

    sim.book_step = counted
    grow_fully(sim, 3000)
    return tests


def bench(runtime, sizes=None) -> list[dict]:
    """Space colonization (book scene values, sphere cloud, the default repeat guard so that growth ends): seconds
    and steps until the tree is fully grown, steps/s over that growth, and the uniform grid's speed-up over the
    book's all-pairs loops ("all_pairs tiled" where the device runs their _tiled kernels, a GPU's; all-pairs is
    skipped where one tree would take minutes). pair flop/s (all pairs):
    PAIR_FLOPS x all_pairs_tests over the growth's seconds; the grid rows have "-": the pairs its 3x3x3 cells hold
    change every step and are not counted on the host."""
    sizes = sizes or ([4096, 16384, 65536, 262144] if runtime.is_gpu else [1736, 4096, 16384])
    all_pairs_limit = 70000 if runtime.is_gpu else 20000
    rows = []
    for size in sizes:
        side = side_for(size)
        seconds = {}
        for search in ("all_pairs", "grid"):
            sim = Simulation(runtime, Params(side=side, search=search), seed=0)
            if search == "all_pairs" and sim.attraction_count > all_pairs_limit:
                rows.append(
                    {
                        "A": sim.attraction_count,
                        "search": search,
                        "steps": "-",
                        "s to grow": "-",
                        "steps/s": "-",
                        "nodes": "-",
                        "speed-up": "-",
                        "pair flop/s": "-",
                    }
                )
                continue
            steps, secs, last = grow_fully(sim, 3000)
            seconds[search] = secs
            speed_up = seconds["all_pairs"] / secs if search == "grid" and "all_pairs" in seconds else "-"
            rows.append(
                {
                    "A": sim.attraction_count,
                    "search": "all_pairs tiled" if search == "all_pairs" and sim.tiles else search,
                    "steps": last,
                    "s to grow": secs,
                    "steps/s": steps / secs,
                    "nodes": sim.live_nodes,
                    "speed-up": speed_up,
                    "pair flop/s": PAIR_FLOPS * all_pairs_tests(runtime, side) / secs if search == "all_pairs" else "-",
                }
            )
    return rows
