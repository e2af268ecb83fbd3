"""GPU-based cellular growth: cells that grow, repel and divide, alone or joined into a network of springs
(Unity Graphics Programming vol.3 ch.4, after iGeo's "Cell Division and Growth Algorithm 1";
docs/chapters/11-cellular-growth.md).

Three scenes, one kernel file (``clkernels/cellular_growth.cl``):

* ``cellular_growth_particles`` (the book's CellularGrowthParticleOnly.cs): reset = ``InitParticles``; each step
  ``EmitParticles`` (while emitting), ``UpdateParticles`` (ping-pong, then swap) and, every ``divide_interval``
  seconds, Divide = ``GetDividableParticles`` then ``DivideParticles``.
* ``cellular_growth`` (CellularGrowth.cs): reset = ``InitParticles``, ``InitEdges``, ``EmitParticles`` of one cell;
  each step ``iterations`` x (``UpdateEdges``, ``SpringEdges``, ``UpdateParticles``) and every ``divide_interval``
  Divide = ``GetDividableEdges`` then ``DivideUnconnectedParticles`` (no dividable edge) or the pattern's kernel,
  ``DivideEdgesClosed`` (a growing ring) or ``DivideEdgesBranch`` (a growing tree).
* ``cellular_growth_sphere`` (CellularGrowthSphere.unity): the network scene with the sphere scene's values, drawn
  as lit sphere impostors.

The host limits every consuming dispatch by the pool counts as the book does (its ``CopyCount`` = ``Pool.count()``):
emit ``min(emit_count, pool)``, divide particles ``min(dividable, max_divide_count, pool)``, divide edges
``min(dividable, max_divide_count, particle pool, edge pool)``.

Differences from the book (``variant=fixed``, the default; ``variant=book`` keeps the book's host limits):
the Closed limit uses edge pool // 2, since a triangle split takes two edge slots, and
``DivideUnconnectedParticles`` lets only min(particle pool, edge pool) work-items divide (a ticket counter) and reads
parents from a snapshot (the book's launch can race on a slot turning from dead to child). A consume that finds a
pool empty returns no slot and is counted in ``faults`` (HLSL: undefined behaviour), so ``variant=book`` runs out of
slots safely. ``book_text`` selects the four formulas printed in the book instead of the repository's (which made the
figures). ``search=grid`` finds repulsion partners through ``ugpcl.grid.UniformGrid`` instead of all pairs, and each
cell's edges through its edge ends sorted by cell (``EdgeEndKeys``, ``SpringEdges_sorted``) instead of a scan of
every edge slot: a step then costs passes over the slots plus work per live cell, not live cells x capacity.
The init kernels fill the pools in a fixed order, slot 0 on top (the book: atomic order), so cells and edges take
slots 0, 1, 2, ...: the views read back and draw only the live prefix (``live_records``), not the capacity.
``normalize(0)`` is guarded everywhere it could occur. ``seed`` shifts the book's clock ``_Time`` (every random draw
is ``nrand`` of an index and the time) by ``SEED_CLOCK_OFFSET`` seconds per seed. The network scenes' first cell starts
at radius ``START_RADIUS`` (0.1) rather than the book's nrand(0, 0) = 0, which stays 0 and shows nothing until the
first Divide gives it 0.1 (``Simulation._start``): the same cells from that Divide on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..buffers import PingPong, Pool
from ..grid import UniformGrid
from ..scene import Animation, AtScale, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

PARTICLE_DTYPE = np.dtype(
    [
        ("position", "<f4", 2),
        ("velocity", "<f4", 2),
        ("radius", "<f4"),
        ("threshold", "<f4"),
        ("links", "<i4"),
        ("alive", "<u4"),
    ]
)
"""Mirror of ``Particle`` in clkernels/include/cellular_growth.h (32 bytes; book: Particle_t)."""
EDGE_DTYPE = np.dtype([("a", "<i4"), ("b", "<i4"), ("force", "<f4", 2), ("alive", "<u4")])
"""Mirror of ``Edge`` (20 bytes; book: Edge_t; the device struct spells the force as fx, fy)."""

GROUP_SIZE = 128
"""Work-group size of every kernel (book: #define THREAD [numthreads(128, 1, 1)])."""
INITIAL_EMIT_COUNT = 1
"""Cells the network scenes emit at the origin on reset (book: EmitParticlesKernel(Vector2.zero, 1))."""
START_RADIUS = 0.1
"""Smallest radius of the network scenes' first cell (ugpcl): the radius the book's first Divide gives it."""
MAX_RADIUS = 1.0
"""No radius ever exceeds 1: emitted thresholds are 1 and a child's is at most 2 x max(r / 2, 0.1) <= 1."""
GRID_CELL_MARGIN = 1.001
"""The grid cell is this much larger than the largest contact distance 2 x MAX_RADIUS x repulsion (float rounding)."""
SEED_CLOCK_OFFSET = 100.0
"""Seconds added to the kernels' clock (the book's _Time) per unit of seed: seed 0 is the book's clock."""
PATTERNS = ("closed", "branch")
"""Divide patterns (book: enum DividePattern { Closed, Branch })."""


# {{{ parameters


@dataclass(frozen=True)
class ParticleParams(BaseParams):
    count: int = param(8192, 2, 1 << 20)
    """Capacity of particles, edges and every pool (book: count; scenes 8192, script default 4096)."""
    size: float = param(0.9, 0.1, 1.5, live=True)
    """Render scale of a cell: its quad is radius x 2 x size wide (book: size)."""
    grow: float = param(0.25, 0.01, 1.0, live=True)
    """Growth rate per second: radius += dt x grow x radius (book text: + dt x grow) (book: grow, _Grow)."""
    divide_interval: float = param(0.5, 0.02, 3.0, live=True)
    """Seconds between Divide calls (book: divideInterval)."""
    max_divide_count: int = param(32, 1, 128, live=True)
    """Most divisions per Divide call (book: maxDivideCount)."""
    drag: float = param(0.975, 0.1, 1.0, live=True)
    """Velocity damping factor per update (book: drag, _Drag)."""
    limit: float = param(5.0, 0.1, 5.0, live=True)
    """Largest step per update, world units, and largest speed (book: limit, _Limit)."""
    repulsion: float = param(1.0, 1.0, 5.0, live=True)
    """Cells closer than (ra + rb) x repulsion push apart (book: repulsion, _Repulsion)."""
    emit_count: int = param(8, 1, 1 << 20, live=True)
    """Cells per emit call while emitting (book: EmitParticlesKernel's emitCount; 8 in the repository, 32 in the
    text)."""
    emit_frames: int = param(10, 0, 1 << 20, live=True)
    """Headless script: the first emit_frames steps emit emit_count cells around the origin (the book emits while the
    left mouse button is held)."""
    search: str = param("all_pairs", choices=("all_pairs", "grid"), live=True)
    """Repulsion partners: the book's loop over every slot, or the 3x3 cells of a uniform grid (ugpcl); grid also
    finds each cell's edges (SpringEdges) through its sorted edge ends instead of a scan of every edge slot."""
    variant: str = param("fixed", choices=("book", "fixed"), live=True)
    """Host limits of the divide kernels: the book's, or with the two-edge Closed guard and the
    DivideUnconnectedParticles ticket and snapshot (see the module docstring)."""
    book_text: bool = param(False)
    """Use the formulas printed in the book (linear growth, child threshold lerp 1.25-2, random offset radius x 0.25,
    no wobble) instead of the repository's."""
    camera: str = param("fit", choices=("fit", "book"), live=True)
    """Headless PNG camera: fit the live cells (+10 %) or the book's fixed orthographic view (size 10 at (0, 1))."""


@dataclass(frozen=True)
class Params(ParticleParams):
    """The network scenes (CellularGrowth.unity, CellularGrowthSphere.unity): the cells' fields plus the edges'.
    Where the scene files differ from ParticleOnly's values, NETWORK_DEFAULTS and SPHERE_DEFAULTS say so."""

    spring: float = param(5.0, 1.0, 10.0, live=True)
    """Edge spring strength (book: spring, _Spring)."""
    pattern: str = param("closed", choices=PATTERNS, live=True)
    """Divide pattern: closed (a ring, fig 4.6-4.8) or branch (a tree, fig 4.9-4.12) (book: pattern)."""
    max_link: int = param(3, 2, 6, live=True)
    """An edge is not dividable when both its cells have this many links (book: maxLink, _MaxLink)."""
    iterations: int = param(2, 1, 16, live=True)
    """UpdateEdges, SpringEdges, UpdateParticles passes per step (book: iterations)."""
    render: str = param("edges", choices=("edges", "discs", "spheres"), live=True)
    """Look of the view (V key): discs joined by edge lines, discs only, or lit sphere impostors."""
    sphere_depth: str = param("radius", choices=("radius", "book"), live=True, used_only_when={"render": "spheres"})
    """Depth of a sphere impostor's surface: radius x size (correct) or the book's constant size (ParticleSphere)."""


NETWORK_DEFAULTS = {
    "grow": 0.25,
    "divide_interval": 0.25,
    "max_divide_count": 64,
    "drag": 0.985,
    "limit": 1.0,
    "repulsion": 2.2,
    "emit_frames": 0,
}
"""CellularGrowth.unity's values where they differ from CellularGrowthParticleOnly.unity's."""

SPHERE_DEFAULTS = {
    **NETWORK_DEFAULTS,
    "size": 1.45,
    "grow": 0.5,
    "divide_interval": 0.1,
    "max_divide_count": 64,
    "drag": 0.925,
    "limit": 2.0,
    "repulsion": 2.45,
    "spring": 4.5,
    "pattern": "closed",
    "max_link": 3,
    "render": "spheres",
}
"""CellularGrowthSphere.unity's values (docs/chapters/11-cellular-growth.md, "Parameters")."""


# }}}


class ParticleSimulation(BaseSimulation):
    """CellularGrowthParticleOnly.cs: cells that grow, repel and divide; no edges."""

    Params = ParticleParams
    history = ("alive_count", "edge_count")
    has_edges = False

    # {{{ setup

    def __init__(self, runtime, params: ParticleParams | None = None, seed: int = 0):
        self.count = 0  # no buffers yet: the first reset makes them, a reset of the same count reuses them
        super().__init__(runtime, params, seed)

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program("cellular_growth", BOOK_TEXT=p.book_text)
        if self.count == p.count:
            self.reset_particles()  # the R key: live slots back to the pool, no reallocation
            if self.has_edges:
                self.reset_edges()
        else:
            self._allocate(p.count)
            self.init_particles()
            if self.has_edges:
                self.init_edges()
        self.faults.fill(0)
        self.divides = 0
        self.next_divide = p.divide_interval  # book: IDivider yields one frame, then WaitForSeconds(divideInterval)
        self.emit_point: tuple[float, float] | None = None
        self.grid, self.grid_key = None, None
        self._start()

    def _start(self) -> None:
        """What the scene's Start() does after the init kernels."""

    def _allocate(self, count: int) -> None:
        rt = self.runtime
        self.count = count
        self.particles = PingPong(rt.zeros(count, PARTICLE_DTYPE), rt.zeros(count, PARTICLE_DTYPE))
        self.particle_pool = Pool(rt, count, np.int32, "particle_pool")  # free particle slots, slot 0 on top
        self.dividable = Pool(rt, count, np.int32, "dividable")  # particle (or edge) indices to divide
        self.faults = rt.zeros(1, np.int32)  # consumes that found a pool empty
        self.edges = rt.zeros(count if self.has_edges else 1, EDGE_DTYPE)
        self.edge_pool = Pool(rt, count, np.int32, "edge_pool") if self.has_edges else None
        self.snapshot = rt.zeros(count, PARTICLE_DTYPE) if self.has_edges else None
        self.tickets = rt.zeros(1, np.int32)
        self.slot_ends = rt.zeros(2, np.int32)  # LiveSlotEnds: the live prefixes of particles and edges
        self.edge_ends = None  # search=grid: each cell's edge ends sorted by cell (made on first use)

    def clock(self, time: float | None = None) -> np.float32:
        """The kernels' _Time: seconds since reset (default: now), shifted by the seed."""
        return np.float32((self.time if time is None else time) + self.seed * SEED_CLOCK_OFFSET)

    # }}}

    # {{{ kernels, in the book's order

    def init_particles(self) -> None:
        """InitParticles: every slot dead, every index in the particle pool, slot 0 on top."""
        self.particle_pool.set_count(self.count)
        self.program.kernel("InitParticles").over(
            self.count, GROUP_SIZE, self.particles.read.data, np.int32(self.count), self.particle_pool.items.data
        )

    def emit_particles(self, point=(0.0, 0.0), emit_count: int | None = None, time: float | None = None) -> int:
        """EmitParticles: min(emit_count, pool) new cells 1 unit around ``point``; returns how many."""
        emit_count = self.params.emit_count if emit_count is None else int(emit_count)
        n = max(0, min(emit_count, self.particle_pool.count()))  # book: CopyPoolSize(poolBuffer)
        if n <= 0:
            return 0
        self.program.kernel("EmitParticles").over(
            n,
            GROUP_SIZE,
            self.particles.read.data,
            self.particle_pool.counter.data,
            self.particle_pool.items.data,
            self.faults.data,
            cltypes.make_float2(*point),
            np.int32(n),
            self.clock(time),
        )
        return n

    def update_particles(self, dt: float) -> None:
        """UpdateParticles (search=grid: UpdateParticles_grid) on Read -> Write, then swap."""
        p = self.params
        args = [
            self.particles.read.data,
            self.particles.write.data,
            np.int32(self.count),
            np.float32(dt),
            np.float32(p.grow),
            np.float32(p.repulsion),
            np.float32(p.drag),
            np.float32(p.limit),
        ]
        name = "UpdateParticles"
        if p.search == "grid":
            grid = self._neighbour_grid()
            args += [*grid.geometry_args(), *grid.search_args()]
            name = "UpdateParticles_grid"
        self.program.kernel(name).over(self.count, GROUP_SIZE, *args)
        self.particles.swap()

    def _neighbour_grid(self) -> UniformGrid:
        """Sort the live cells into a uniform grid (cell = largest contact distance): ParticleGridKeys, then the
        grid's counting sort; dead slots get no key. The grid has side = ceil(sqrt(count)) + 2 cells a side, from
        -(side / 2 + 1) cells in x and y (a live cell outside is clamped into the border cells: still exact, only
        slower)."""
        p = self.params
        cell = 2.0 * MAX_RADIUS * p.repulsion * GRID_CELL_MARGIN
        if self.grid is None or self.grid_key != (self.count, cell):
            side = max(8, math.ceil(math.sqrt(self.count)))
            origin = -0.5 * side * cell - 2.0 * cell
            self.grid = UniformGrid(self.runtime, self.count, (origin, origin), cell, (side + 2, side + 2, 1))
            self.grid_key = (self.count, cell)
        self.program.kernel("ParticleGridKeys").over(
            self.count,
            GROUP_SIZE,
            self.particles.read.data,
            np.int32(self.count),
            *self.grid.geometry_args(),
            self.grid.hash_keys,
        )
        self.grid.sort(self.count)
        return self.grid

    def get_dividable_particles(self) -> None:
        """GetDividableParticles: reset the dividable pool, append every live cell with radius >= 0.95 threshold."""
        self.dividable.set_count(0)  # book: dividablePoolBuffer.SetCounterValue(0)
        self.program.kernel("GetDividableParticles").over(
            self.count,
            GROUP_SIZE,
            self.particles.read.data,
            np.int32(self.count),
            self.dividable.counter.data,
            self.dividable.items.data,
        )

    def divide_particles(self, max_divide_count: int | None = None, time: float | None = None) -> int:
        """DivideParticles: min(dividable, max_divide_count, pool) cells split in two at ``time`` (default: now);
        returns how many."""
        wanted = self.params.max_divide_count if max_divide_count is None else max_divide_count
        n = min(self.dividable.count(), wanted)  # book: CopyPoolSize(dividablePoolBuffer)
        n = min(self.particle_pool.count(), n)  # book: CopyPoolSize(poolBuffer)
        if n <= 0:
            return 0
        self.program.kernel("DivideParticles").over(
            n,
            GROUP_SIZE,
            self.particles.read.data,
            self.particle_pool.counter.data,
            self.particle_pool.items.data,
            self.dividable.counter.data,
            self.dividable.items.data,
            self.faults.data,
            np.int32(n),
            self.clock(time),
        )
        return n

    def reset_particles(self) -> None:
        """ResetParticles: every live cell dies and its index goes back to the pool."""
        self.program.kernel("ResetParticles").over(
            self.count,
            GROUP_SIZE,
            self.particles.read.data,
            np.int32(self.count),
            self.particle_pool.counter.data,
            self.particle_pool.items.data,
        )

    # }}}

    def divide(self, time: float | None = None) -> int:
        """The book's Divide() at ``time`` (default: now): collect the dividable cells, split up to
        max_divide_count; returns the splits."""
        self.get_dividable_particles()
        made = self.divide_particles(time=time)
        self.divides += 1
        return made

    def emit_at(self, point: tuple[float, float] | None) -> None:
        """Emit emit_count cells around ``point`` on every step until ``emit_at(None)`` (the held mouse button)."""
        self.emit_point = None if point is None else (float(point[0]), float(point[1]))

    def _emitting(self) -> tuple[float, float] | None:
        if self.emit_point is not None:
            return self.emit_point
        return (0.0, 0.0) if self.steps < self.params.emit_frames else None

    def _divide_if_due(self, time: float) -> None:
        """IDivider: one Divide after the step in which the clock reached the next tick (at most one per step);
        ``time`` is the clock at the end of the step."""
        if time + 1e-9 >= self.next_divide:
            self.divide(time)
            self.next_divide = max(self.next_divide + self.params.divide_interval, time)

    def _step(self, dt: float) -> None:
        point = self._emitting()
        if point is not None:
            self.emit_particles(point, time=self.time + dt)
        self.update_particles(dt)
        self._divide_if_due(self.time + dt)

    # {{{ state

    def live_slot_ends(self) -> tuple[int, int]:
        """(particles, edges): one past the last live particle slot (or cell a live edge names) and live edge slot,
        from LiveSlotEnds in one device read. The pools hand out slots from 0 up, so these follow the live counts."""
        self.slot_ends.fill(0)
        self.program.kernel("LiveSlotEnds").over(
            self.count,
            GROUP_SIZE,
            self.particles.read.data,
            self.edges.data,
            np.int32(self.count),
            np.int32(self.count if self.has_edges else 0),
            self.slot_ends.data,
        )
        ends = self.runtime.read_back(self.slot_ends)
        return int(ends[0]), int(ends[1])

    def live_records(self) -> tuple[np.ndarray, np.ndarray]:
        """The Particle and Edge records of the live prefixes (``live_slot_ends``) for the views: page-locked host
        copies (``Runtime.read_back``) that the next call overwrites. Every live cell and edge is in them."""
        particles, edges = self.live_slot_ends()
        read = self.runtime.read_back
        return read(self.particles.read, particles), read(self.edges, edges)

    def particle_records(self) -> np.ndarray:
        """The Particle records (count,) of PARTICLE_DTYPE: the newest state (Read)."""
        return self.particles.read.get()

    def edge_records(self) -> np.ndarray:
        """The Edge records (count,) of EDGE_DTYPE (empty in the particle-only scene)."""
        return self.edges.get() if self.has_edges else np.zeros(0, EDGE_DTYPE)

    def fault_count(self) -> int:
        """Consumes that found a pool empty since reset (0 whenever the host's limits hold)."""
        return int(self.faults.get()[0])

    def load(self, particles: np.ndarray, edges: np.ndarray | None = None) -> None:
        """Replace the state by hand (tests, benchmarks): full slot arrays; pools get every dead index, ascending."""
        particles = np.asarray(particles, PARTICLE_DTYPE)
        if particles.shape != (self.count,):
            raise ValueError(f"particles must have shape ({self.count},), got {particles.shape}")
        self.particles.read.set(particles)
        self.particles.write.set(particles)
        self.particle_pool.fill(np.flatnonzero(particles["alive"] == 0))
        if self.has_edges:
            edges = np.zeros(self.count, EDGE_DTYPE) if edges is None else np.asarray(edges, EDGE_DTYPE)
            if edges.shape != (self.count,):
                raise ValueError(f"edges must have shape ({self.count},), got {edges.shape}")
            self.edges.set(edges)
            self.edge_pool.fill(np.flatnonzero(edges["alive"] == 0))

    def state(self) -> dict[str, np.ndarray]:
        parts = self.particle_records()
        edges = self.edge_records()
        live = edges[edges["alive"] != 0]
        alive = parts["alive"] != 0
        return {
            "position": np.ascontiguousarray(parts["position"]),
            "velocity": np.ascontiguousarray(parts["velocity"]),
            "radius": np.ascontiguousarray(parts["radius"]),
            "threshold": np.ascontiguousarray(parts["threshold"]),
            "links": np.ascontiguousarray(parts["links"]),
            "alive": alive,
            "edges": np.ascontiguousarray(np.column_stack([live["a"], live["b"]]).astype(np.int32).reshape(-1, 2)),
            "edge_force": np.ascontiguousarray(live["force"].reshape(-1, 2)),
            "particle_pool_count": np.int32(self.particle_pool.count()),
            "edge_pool_count": np.int32(self.edge_pool.count() if self.has_edges else 0),
            "pool_indices": self.particle_pool.read().astype(np.int32),
            "edge_pool_indices": (self.edge_pool.read() if self.has_edges else np.zeros(0)).astype(np.int32),
            "alive_count": np.int32(alive.sum()),
            "edge_count": np.int32(len(live)),
            "time": np.float32(self.time),
            "divides": np.int32(self.divides),
            "faults": np.int32(self.fault_count()),
        }

    def stats(self) -> dict:
        alive = int((self.particle_records()["alive"] != 0).sum())
        out = {
            **super().stats(),
            "cells": f"{alive} / {self.count}",
            "particle pool": self.particle_pool.count(),
        }
        if self.has_edges:
            edges = int((self.edge_records()["alive"] != 0).sum())
            out.update({"edges": edges, "edge pool": self.edge_pool.count(), "pattern": self.params.pattern})
        out.update({"divides": self.divides, "faults": self.fault_count(), "search": self.params.search})
        return out

    # }}}


class Simulation(ParticleSimulation):
    """CellularGrowth.cs: cells joined by edges (springs); edges divide in the Closed or Branch pattern."""

    Params = Params
    has_edges = True

    def _start(self) -> None:
        """Book Start(): EmitParticlesKernel(Vector2.zero, 1) before the first Update. At _Time 0 the cell's radius is
        nrand(0, 0) = 0, which the repository's growth (radius += dt grow radius) keeps at 0: an invisible cell, and
        a black picture, until the first DivideUnconnectedParticles splits it into two cells of max(r / 2, 0.1) =
        0.1. ugpcl starts the cell at START_RADIUS (0.1) instead: it shows from the first step, and the first Divide
        still makes the book's two cells of radius 0.1 (r / 2 < 0.1 either way). The book's printed linear growth
        lifts a radius of 0 by itself, so book_text keeps it."""
        self.emit_particles((0.0, 0.0), INITIAL_EMIT_COUNT, time=0.0)
        if not self.params.book_text:
            records = self.particles.read.get()
            alive = records["alive"] != 0
            records["radius"][alive] = np.maximum(records["radius"][alive], START_RADIUS)
            self.particles.read.set(records)

    # {{{ edge kernels, in the book's order

    def init_edges(self) -> None:
        """InitEdges: every edge dead, every index in the edge pool, slot 0 on top."""
        self.edge_pool.set_count(self.count)
        self.program.kernel("InitEdges").over(
            self.count, GROUP_SIZE, self.edges.data, np.int32(self.count), self.edge_pool.items.data
        )

    def update_edges(self) -> None:
        """UpdateEdges: each live edge's spring force."""
        self.program.kernel("UpdateEdges").over(
            self.count,
            GROUP_SIZE,
            self.particles.read.data,
            self.edges.data,
            np.int32(self.count),
            np.float32(self.params.spring),
        )

    def spring_edges(self) -> None:
        """SpringEdges: every live cell adds -+force / links of its edges to its velocity (in place on Read).
        search=grid: SpringEdges_sorted, the same sums over each cell's own edges (``_edge_ends``)."""
        args = (self.particles.read.data, self.edges.data, np.int32(self.count))
        if self.params.search == "grid":
            ends = self._edge_ends()
            self.program.kernel("SpringEdges_sorted").over(self.count, GROUP_SIZE, *args, *ends.search_args())
        else:
            self.program.kernel("SpringEdges").over(self.count, GROUP_SIZE, *args)

    def _edge_ends(self) -> UniformGrid:
        """Each cell's live edge ends in edge order: EdgeEndKeys, then the uniform grid's counting sort with a
        particle slot for a grid cell (2 x count keys, count cells; the geometry is unused)."""
        if self.edge_ends is None:
            self.edge_ends = UniformGrid(self.runtime, 2 * self.count, (0.0, 0.0), 1.0, (self.count, 1, 1))
        self.program.kernel("EdgeEndKeys").over(
            self.count, GROUP_SIZE, self.edges.data, np.int32(self.count), self.edge_ends.hash_keys
        )
        self.edge_ends.sort(2 * self.count)
        return self.edge_ends

    def get_dividable_edges(self) -> None:
        """GetDividableEdges: reset the dividable pool, append every live edge whose two cells may divide."""
        self.dividable.set_count(0)  # book: dividablePoolBuffer.SetCounterValue(0)
        self.program.kernel("GetDividableEdges").over(
            self.count,
            GROUP_SIZE,
            self.particles.read.data,
            self.edges.data,
            np.int32(self.count),
            self.dividable.counter.data,
            self.dividable.items.data,
            np.int32(self.params.max_link),
        )

    def divide_unconnected_particles(self, time: float | None = None) -> None:
        """DivideUnconnectedParticles over every slot: each live cell without links splits and links to its child.
        variant=fixed: at most min(particle pool, edge pool) of them, parents read from a snapshot."""
        q = self.runtime.queue
        if self.params.variant == "fixed":
            limit = min(self.particle_pool.count(), self.edge_pool.count())
            cl.enqueue_copy(q, self.snapshot.data, self.particles.read.data)
            parents = self.snapshot
        else:
            limit, parents = np.iinfo(np.int32).max, self.particles.read  # book: no limit, in place
        self.tickets.fill(0)
        pools = (
            self.particle_pool.counter.data,
            self.particle_pool.items.data,
            self.edges.data,
            self.edge_pool.counter.data,
            self.edge_pool.items.data,
        )
        self.program.kernel("DivideUnconnectedParticles").over(
            self.count,
            GROUP_SIZE,
            parents.data,
            self.particles.read.data,
            np.int32(self.count),
            *pools,
            self.tickets.data,
            np.int32(limit),
            self.faults.data,
            self.clock(time),
        )

    def _divide_edges(
        self, name: str, dividable_edges: int, max_divide_count: int | None = None, time: float | None = None
    ) -> int:
        """The book's DivideEdgesKernel: min(dividable, max, particle pool, edge pool) work-items of ``name``."""
        p = self.params
        n = min(dividable_edges, p.max_divide_count if max_divide_count is None else max_divide_count)
        n = min(self.particle_pool.count(), n)  # book: particlePool.CopyPoolSize()
        edge_slots = self.edge_pool.count()  # book: edgePool.CopyPoolSize()
        if name == "DivideEdgesClosed" and p.variant == "fixed":
            edge_slots //= 2  # ugpcl: a triangle split takes two edge slots
        n = min(edge_slots, n)
        if n <= 0:
            return 0
        self.program.kernel(name).over(
            n,
            GROUP_SIZE,
            self.particles.read.data,
            self.particle_pool.counter.data,
            self.particle_pool.items.data,
            self.edges.data,
            self.edge_pool.counter.data,
            self.edge_pool.items.data,
            self.dividable.counter.data,
            self.dividable.items.data,
            self.faults.data,
            np.int32(n),
            self.clock(time),
        )
        return n

    def divide_edges_closed(self, dividable_edges: int, max_divide_count: int | None = None, time=None) -> int:
        """DivideEdgesClosed: a child inserted into each dividable edge (or a triangle); returns the splits."""
        return self._divide_edges("DivideEdgesClosed", dividable_edges, max_divide_count, time)

    def divide_edges_branch(self, dividable_edges: int, max_divide_count: int | None = None, time=None) -> int:
        """DivideEdgesBranch: a child hung on the less-linked end of each dividable edge; returns the splits."""
        return self._divide_edges("DivideEdgesBranch", dividable_edges, max_divide_count, time)

    def reset_edges(self) -> None:
        """ResetEdges: every live edge dies and its index goes back to the edge pool."""
        self.program.kernel("ResetEdges").over(
            self.count,
            GROUP_SIZE,
            self.edges.data,
            np.int32(self.count),
            self.edge_pool.counter.data,
            self.edge_pool.items.data,
        )

    # }}}

    def divide(self, time: float | None = None) -> int:
        """The book's Divide() at ``time`` (default: now): split dividable edges in the pattern, or lone cells when
        no edge is dividable. Returns the edge splits dispatched (0 after DivideUnconnectedParticles)."""
        self.get_dividable_edges()
        dividable_edges = self.dividable.count()  # book: CopyPoolSize(dividablePoolBuffer)
        self.divides += 1
        if dividable_edges == 0:
            self.divide_unconnected_particles(time)
            return 0
        if self.params.pattern == "closed":
            return self.divide_edges_closed(dividable_edges, time=time)
        return self.divide_edges_branch(dividable_edges, time=time)

    def _step(self, dt: float) -> None:
        point = self._emitting()
        if point is not None:
            self.emit_particles(point, time=self.time + dt)
        for _ in range(self.params.iterations):  # book Update(): UpdateEdges, SpringEdges, UpdateParticles
            self.update_edges()
            self.spring_edges()
            self.update_particles(dt)
        self._divide_if_due(self.time + dt)


SCENES = [
    Scene(
        "cellular_growth",
        Simulation,
        "Cellular growth: dividing cells joined by springs grow a closed ring or a branching tree (vol.3 ch.4)",
        defaults=NETWORK_DEFAULTS,
        view="View",
        preview={"steps": 900, "count": 1024},
        animation=Animation(
            "cells divide and grow into the ring (the book's fixed camera: the fitted one would frame the first cells "
            "only)",
            every=12,
            start=360,
            overrides={"camera": "book"},
        ),
        at_scale=AtScale(gpu={"count": 1 << 20, "search": "grid"}, cpu={"count": 1 << 14, "search": "grid"}),
    ),
    Scene(
        "cellular_growth_particles",
        ParticleSimulation,
        "Cellular growth, cells only: emitted cells grow, repel and divide (vol.3 ch.4)",
        view="ParticleView",
        preview={"steps": 600, "count": 2048},
    ),
    Scene(
        "cellular_growth_sphere",
        Simulation,
        "Cellular growth drawn as lit spheres (CellularGrowthSphere, vol.3 ch.4)",
        defaults=SPHERE_DEFAULTS,
        view="SphereView",
        preview={"steps": 600, "count": 1024},
    ),
]
