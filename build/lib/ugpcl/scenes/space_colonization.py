"""GPU-based space colonization: a tree grows through a cloud of attraction points (vol.4 ch.1; spec 12).

Kernel order (clkernels/space_colonization.cl): ``reset`` runs Setup (every node slot into the pool), Seed
(``seed_count`` nodes on random attraction points) and one step; each ``step`` runs, while the node pool is not
empty, Search (nearest node of every attraction within the influence distance), Attract (every grown node pulled by
an attraction proposes a candidate one growth distance along the mean unit vector), Connect (candidates become
nodes joined by edges; never more than the free slots), Remove (attractions within the kill distance of a node die)
and reads the pool and edge counts back; then always Grow (t += dt * growth_speed * mass). A node branches only once
t reaches 1, which is also what animates the edges in the view.

Scenes: ``space_colonization`` and ``space_colonization_tubes`` (the book's Line and TubularEdge scenes),
``space_colonization_skinned`` (the book's skinning application, on a procedural figure: SkinnedSimulation,
clkernels/space_colonization_skinned.cl) and ``space_colonization_cpu`` (the blog's CPU algorithm,
ugpcl.geometry.space_colonization_ref.BlogTree, which with ColonizationRef is also the tests' oracle).

Differences from the book: attractions closer than 1e-12 to their node are skipped in Attract (the book's seeds sit
on attraction points and make NaN nodes); ``repeat_guard`` (off by default) stops a node emitting its last candidate
again or one on itself (cancelling attractions otherwise drain the pool with copies); ``search=grid`` replaces the
all-pairs loops of Search, Attract and Remove by uniform-grid lookups with the same results; the attractions are
stored sorted by grid cell (a permutation of the book's cloud) so that both modes sum Attract's unit vectors in the
same order; the book's Connect rewrites the parent unchanged (left out).
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..buffers import Pool
from ..geometry import skinned_figure
from ..geometry import space_colonization_ref as ref
from ..geometry.mesh_io import write_mesh
from ..grid import LOCAL_SIZE as GRID_LOCAL_SIZE
from ..grid import UniformGrid, next_power_of_two
from ..runtime import round_up
from ..scene import Params as BaseParams
from ..scene import Scene, check_dt, param
from ..scene import Simulation as BaseSimulation

# {{{ records (clkernels/include/space_colonization.h)

ATTRACTION_DTYPE = np.dtype([("position", "<f4", 3), ("nearest", "<i4"), ("found", "<u4"), ("active", "<u4")])
"""Mirror of Attraction (24 bytes)."""
NODE_DTYPE = np.dtype(
    [("position", "<f4", 3), ("t", "<f4"), ("offset", "<f4"), ("mass", "<f4"), ("from", "<i4"), ("active", "<u4")]
)
"""Mirror of Node (32 bytes)."""
CANDIDATE_DTYPE = np.dtype([("position", "<f4", 3), ("node", "<i4")])
"""Mirror of Candidate (16 bytes)."""
EDGE_DTYPE = np.dtype([("a", "<i4"), ("b", "<i4")])
"""Mirror of Edge (8 bytes)."""

# }}}

LOCAL_SIZE = 128
"""Work-group size of every kernel (book: [numthreads(128,1,1)])."""


# {{{ plain scene


@dataclass(frozen=True)
class Params(BaseParams):
    side: int = param(28, 4, 160)
    """Grid resolution of the attraction cloud: side^3 grid points, those inside the sphere kept (book: count)."""
    cloud: str = param("sphere", choices=("sphere", "hemisphere", "box"))
    """Shape of the attraction cloud: the book's sphere, the blog's hemisphere generator, or a filled cube."""
    seed_count: int = param(6, 1, 256)
    """Initial nodes, placed on random attraction points (book: seedCount)."""
    influence_distance: float = param(1.14, 0.0, lo_open=True)
    """An attraction pulls its nearest node within this distance, in units of `unit` (book: influenceDistance)."""
    growth_distance: float = param(0.597, 0.0, lo_open=True)
    """Length of one new branch, in units of `unit` (book: growthDistance)."""
    kill_distance: float = param(0.484, 0.0, lo_open=True)
    """An attraction this close to any node is removed, in units of `unit` (book: killDistance)."""
    growth_speed: float = param(22.0, 0.0, lo_open=True)
    """t grows by dt * growth_speed * mass per step, 1/s (book: growthSpeed)."""
    mass_min: float = param(0.25, 0.0, lo_open=True)
    """Lower bound of the per-node growth-speed factor (book: massMin)."""
    mass_max: float = param(1.0, 0.0, lo_open=True)
    """Upper bound of the per-node growth-speed factor (book: massMax)."""
    frame: int = param(1, 1, 60)
    """Run the algorithm every `frame` steps (book: frame)."""
    iterations: int = param(1, 1, 5)
    """Algorithm steps per run, each with the same dt (book: iterations)."""
    repeat_guard: bool = False
    """A node does not emit the candidate it emitted last time (ugpcl; off = the book, whose cancelling
    attractions can drain the node pool with copies of one node)."""
    node_capacity: int = param(0, 0, 1 << 24)
    """Node slots (0: one per attraction, as the book). Fewer slots show the pool running dry."""
    search: str = param("all_pairs", choices=("all_pairs", "grid"))
    """Neighbour lookups of Search, Attract and Remove: the book's loops over every slot, or a uniform grid
    (cell = the larger of influence and kill distance): same results, far fewer distance tests."""
    render: str = param("lines", choices=("lines", "tubes"))
    """How the view draws the edges: additive lines (book: Line scene, Edge.shader) or capsules (TubularEdge scene)."""
    tube_radius: float = param(0.0055, 0.0, lo_open=True)
    """Tube radius of the view and of --mesh, cloud units (book: _Thickness 0.033 at object scale 6)."""
    mesh_kind: str = param("tubes", choices=("tubes", "lines"))
    """What --mesh writes: closed capsules per edge, or OBJ polylines (`l`)."""
    object_scale: float = param(6.0, 0.0, lo_open=True)
    """Drawing scale of the cloud (book: the SpaceColonization object's transform), render only."""

    def check(self) -> None:
        if self.mass_min > self.mass_max:
            raise ValueError(f"mass_min must be <= mass_max, got {self.mass_min} > {self.mass_max}")

    @property
    def unit(self) -> float:
        """Distance unit: 2 / side (book: unitDistance), so finer clouds grow finer branches."""
        return 2.0 / self.side


def make_cloud(p: Params, rng: np.random.Generator) -> np.ndarray:
    if p.cloud == "sphere":
        return ref.sphere_cloud(p.side, rng)
    if p.cloud == "box":
        return ref.box_cloud(p.side, rng)
    # the blog's generator in cloud units: as many points as the sphere, a dome of radius 0.5 standing on y = -0.25
    n = len(ref.sphere_cloud(p.side, np.random.default_rng(0)))
    return ref.hemisphere_cloud(n, 0.5, 0.0, 1.0, -0.25, rng)


class NodeGrid(UniformGrid):
    """The uniform grid of the active nodes: NodeGridHash keys only the active slots (the rest get empty keys, which
    sort last and own no cell), then ``UniformGrid.sort`` as for any grid."""

    def build_active(self, program, nodes, slots: int) -> None:
        padded = next_power_of_two(max(slots, 1))
        program.kernel("NodeGridHash")(
            self.runtime.queue,
            (round_up(padded, GRID_LOCAL_SIZE),),
            None,
            nodes.data,
            np.int32(slots),
            np.int32(padded),
            *self.geometry_args(),
            self.keys.data,
        )
        self.sort(slots)


class Simulation(BaseSimulation):
    """The book's SpaceColonization.cs: attraction, node, candidate and edge buffers; Step per frame."""

    Params = Params
    history = ("node_count", "active_attraction")
    live_params = frozenset(
        {
            "influence_distance",
            "growth_distance",
            "kill_distance",
            "growth_speed",
            "mass_min",
            "mass_max",
            "frame",
            "iterations",
            "repeat_guard",
            "search",
            "render",
            "tube_radius",
            "mesh_kind",
            "object_scale",
        }
    )
    program_stem = "space_colonization"

    # {{{ setup

    def reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program(self.program_stem)
        rng = np.random.default_rng(self.seed)
        cloud = make_cloud(p, rng)
        seeds = cloud[rng.integers(0, len(cloud), p.seed_count)]  # book: attractions[Random.Range(0, count)]
        self.unit = p.unit
        self._allocate(cloud, p.node_capacity or len(cloud))
        self.setup()
        self.seed_nodes(seeds)
        self.nodes_count = self.node_pool.count()  # book: CopyNodesCount (A - seeds)
        self.edges_count = 0
        self.time, self.steps, self.frame_index = 0.0, 0, 0
        self.last_growth_step, self.last_connect = 0, 0
        self.book_step(0.0)  # the book's Start ends with Step(0): the seeds branch at once

    def _allocate(self, cloud: np.ndarray, capacity: int) -> None:
        rt = self.runtime
        self.count, self.capacity = len(cloud), int(capacity)
        records = np.zeros(self.count, ATTRACTION_DTYPE)
        records["position"], records["nearest"], records["active"] = cloud, -1, 1
        self.attractions = rt.to_device(records)
        self.nodes = rt.zeros(self.capacity, NODE_DTYPE)
        self.node_pool = Pool(rt, self.capacity, np.int32, "node_pool")
        self.candidates = Pool(rt, self.capacity, CANDIDATE_DTYPE, "candidates")  # <= one per node per step
        self.edges = Pool(rt, 2 * self.capacity, EDGE_DTYPE, "edges")  # book: count * 2
        self.last_candidate = rt.zeros(self.capacity, cltypes.float4)  # repeat_guard: (last candidate, emitted)
        self.lower = cloud.min(axis=0) if len(cloud) else np.zeros(3)
        self.upper = cloud.max(axis=0) if len(cloud) else np.ones(3)
        self.grid_cell = 0.0
        self._sort_attractions_by_cell()

    def _grid_cell_size(self) -> float:
        p = self.params
        return max(p.influence_distance, p.kill_distance) * self.unit

    def _sort_attractions_by_cell(self) -> None:
        """Build the attraction and node grids for the current radii and store the attractions sorted by cell
        (device keys, so host and device agree on every cell). Nothing refers to attraction indices across steps
        (Search rewrites `nearest`), so the permutation changes no result."""
        rt, cell = self.runtime, self._grid_cell_size()
        self.grid_cell = cell
        self.attraction_grid = UniformGrid.covering(rt, max(self.count, 1), self.lower, self.upper + 1e-6, cell)
        self.node_grid = NodeGrid(rt, self.capacity, self.attraction_grid.origin, cell, self.attraction_grid.dims)
        self.attraction_grid.build(self.attractions, self.count, ATTRACTION_DTYPE.itemsize // 4, 0)
        order = (self.attraction_grid.sorted_keys() & np.uint64(0xFFFFFFFF)).astype(np.int64)
        self.attractions.set(self.attractions.get()[order])
        self.attraction_grid.build(self.attractions, self.count, ATTRACTION_DTYPE.itemsize // 4, 0)
        self.node_grid_stale = True

    def _launch(self, name: str, n: int, *args) -> None:
        if n > 0:
            self.program.kernel(name)(self.runtime.queue, (round_up(n, LOCAL_SIZE),), (LOCAL_SIZE,), *args)

    # }}}

    # {{{ kernels, in the book's order

    def setup(self) -> None:
        """Setup: every node slot into the pool, every node inactive."""
        self.node_pool.set_count(0)
        self._launch(
            "Setup",
            self.capacity,
            self.nodes.data,
            np.int32(self.capacity),
            self.node_pool.counter.data,
            self.node_pool.items.data,
        )

    def seed_nodes(self, seeds: np.ndarray) -> None:
        """Seed (named so because ``seed`` is the random seed): one grown node per seed position."""
        p = self.params
        seeds = np.ascontiguousarray(seeds, np.float32).reshape(-1, 3)
        buffer = self.runtime.to_device(seeds.reshape(-1))
        n = min(len(seeds), self.node_pool.count())  # never more consumers than free slots
        self._launch(
            "Seed",
            n,
            buffer.data,
            np.int32(n),
            self.nodes.data,
            self.node_pool.counter.data,
            self.node_pool.items.data,
            np.float32(p.mass_min),
            np.float32(p.mass_max),
        )
        self.node_grid_stale = True

    def _node_grid(self) -> NodeGrid:
        if self.grid_cell < self._grid_cell_size():  # a radius grew past the cell: the 3x3x3 lookup would miss
            self._sort_attractions_by_cell()
        if self.node_grid_stale:
            self.node_grid.build_active(self.program, self.nodes, self.capacity)
            self.node_grid_stale = False
        return self.node_grid

    def search(self) -> None:
        """Search: nearest active node within the influence distance of every active attraction."""
        self._attractions_to_nodes("Search", self.params.influence_distance * self.unit)

    def attract(self) -> None:
        """Attract: the candidate counter is cleared, then every grown, pulled node appends one candidate."""
        p = self.params
        self.candidates.set_count(0)
        tail = (
            np.float32(p.growth_distance * self.unit),
            np.int32(p.repeat_guard),
            self.last_candidate.data,
            self.candidates.counter.data,
            self.candidates.items.data,
            np.int32(self.capacity),
        )
        if p.search == "grid":
            if self.grid_cell < self._grid_cell_size():
                self._sort_attractions_by_cell()
            grid = self.attraction_grid
            self._launch(
                "Attract_grid",
                self.capacity,
                self.attractions.data,
                self.nodes.data,
                np.int32(self.capacity),
                *tail,
                *grid.geometry_args(),
                *grid.search_args(),
            )
        else:
            self._launch(
                "Attract",
                self.capacity,
                self.attractions.data,
                np.int32(self.count),
                self.nodes.data,
                np.int32(self.capacity),
                *tail,
            )

    def connect(self) -> int:
        """Connect: min(free slots, candidates) work-items each turn a candidate into a node and an edge."""
        p = self.params
        connect_count = min(self.nodes_count, self.candidates.count())  # book: Mathf.Min(nodesCount, CopyCount)
        self._launch(
            "Connect",
            connect_count,
            self.nodes.data,
            self.node_pool.counter.data,
            self.node_pool.items.data,
            self.candidates.counter.data,
            self.candidates.items.data,
            self.edges.counter.data,
            self.edges.items.data,
            np.int32(self.edges.capacity),
            np.int32(connect_count),
            np.float32(p.mass_min),
            np.float32(p.mass_max),
        )
        self.last_connect = connect_count
        if connect_count:
            self.node_grid_stale = True
        return connect_count

    def remove(self) -> None:
        """Remove: attractions within the kill distance of any active node (the new ones included)."""
        self._attractions_to_nodes("Remove", self.params.kill_distance * self.unit)

    def _attractions_to_nodes(self, kernel: str, radius: float) -> None:
        """Search and Remove: every active attraction visits the nodes within ``radius``, all pairs as in the book or
        through the node grid (``<kernel>_grid``)."""
        head = (self.attractions.data, np.int32(self.count), self.nodes.data)
        if self.params.search == "grid":
            grid = self._node_grid()
            tail = (np.float32(radius), *grid.geometry_args(), *grid.search_args())
            self._launch(f"{kernel}_grid", self.count, *head, *tail)
        else:
            self._launch(kernel, self.count, *head, np.int32(self.capacity), np.float32(radius))

    def grow(self, dt: float) -> None:
        """Grow: t = saturate(t + dt * growth_speed * mass) for every active node."""
        dT = np.float32(dt * self.params.growth_speed)
        self._launch("Grow", self.capacity, self.nodes.data, np.int32(self.capacity), dT)

    # }}}

    def book_step(self, dt: float) -> None:
        """The book's Step(dt): the algorithm while the pool has slots, then Grow."""
        if self.nodes_count > 0:  # book: do not run when the object pool is empty
            self.search()
            self.attract()
            made = self.connect()
            self.remove()
            self.nodes_count = self.node_pool.count()  # CopyNodesCount
            self.edges_count = self.edges.count()  # CopyEdgesCount
            if made:
                self.last_growth_step = self.steps
        self.grow(dt)

    def step(self, dt: float | None = None) -> None:
        dt = check_dt(dt, self.default_dt)
        p = self.params
        if self.frame_index % p.frame == 0:  # book: every `frame` frames, `iterations` steps
            for _ in range(p.iterations):
                self.book_step(dt)
        self.frame_index += 1
        self._advance(dt)

    # {{{ state

    def load_state(self, nodes: np.ndarray, attractions: np.ndarray | None = None) -> None:
        """Replace the node records (and the attractions, same count) by hand, for tests and experiments: the pool
        becomes the free slots in ascending order (the top = the highest free index), the edges are cleared."""
        if len(nodes) != self.capacity or (attractions is not None and len(attractions) != self.count):
            raise ValueError(f"load_state needs {self.capacity} nodes and {self.count} attractions")
        self.nodes.set(np.ascontiguousarray(nodes, NODE_DTYPE))
        if attractions is not None:
            self.attractions.set(np.ascontiguousarray(attractions, ATTRACTION_DTYPE))
        free = np.flatnonzero(nodes["active"] == 0).astype(np.int32)
        self.node_pool.fill(free)
        self.nodes_count, self.edges_count = len(free), 0
        self.edges.set_count(0)
        self.last_candidate.set(np.zeros(self.capacity, cltypes.float4))
        self.node_grid_stale = True

    def read_nodes(self) -> np.ndarray:
        return self.nodes.get()

    def read_attractions(self) -> np.ndarray:
        return self.attractions.get()

    def read_edges(self) -> np.ndarray:
        """The live edges (book: the first edgesCount entries of the edge buffer)."""
        out = np.empty(self.edges_count, EDGE_DTYPE)
        if self.edges_count:
            cl.enqueue_copy(self.runtime.queue, out, self.edges.items.data)
        return out

    def state(self) -> dict[str, np.ndarray]:
        nodes, attractions, edges = self.read_nodes(), self.read_attractions(), self.read_edges()
        return {
            "node_position": np.ascontiguousarray(nodes["position"]),
            "node_from": nodes["from"].copy(),
            "node_active": nodes["active"] != 0,
            "node_t": nodes["t"].copy(),
            "node_offset": nodes["offset"].copy(),
            "node_mass": nodes["mass"].copy(),
            "edges": np.column_stack([edges["a"], edges["b"]]).astype(np.int32).reshape(-1, 2),
            "attraction_position": np.ascontiguousarray(attractions["position"]),
            "attraction_active": attractions["active"] != 0,
            "attraction_nearest": attractions["nearest"].copy(),
            "attraction_found": attractions["found"] != 0,
            "nodes_free": np.int32(self.nodes_count),
            "edges_count": np.int32(self.edges_count),
            "node_count": np.int32(self.capacity - self.nodes_count),
            "active_attraction": np.int32((attractions["active"] != 0).sum()),
        }

    def stats(self) -> dict:
        attractions = self.read_attractions()
        return {
            **super().stats(),
            "attractions": self.count,
            "active attractions": int((attractions["active"] != 0).sum()),
            "nodes used": self.capacity - self.nodes_count,
            "nodes free": self.nodes_count,
            "edges": self.edges_count,
            "last growth at step": self.last_growth_step,
            "search": getattr(self.params, "search", "all_pairs"),
        }

    def grown_segments(self) -> tuple[np.ndarray, np.ndarray]:
        """(a, b') per live edge with b' = a + (b - a) * t_b: the branches as drawn (t grows the child's edge)."""
        nodes, edges = self.read_nodes(), self.read_edges()
        a = nodes["position"][edges["a"]].astype(np.float64)
        b = nodes["position"][edges["b"]].astype(np.float64)
        return a, a + (b - a) * nodes["t"][edges["b"]][:, None]

    def export_mesh(self, path) -> None:
        """--mesh: capsules around every grown edge (mesh_kind=tubes) or OBJ polylines (lines), cloud units."""
        a, b = self.grown_segments()
        if self.params.mesh_kind == "lines":
            vertices = np.stack([a, b], axis=1).reshape(-1, 3)
            write_mesh(path, vertices, lines=np.arange(len(vertices)).reshape(-1, 2))
        else:
            vertices, normals, triangles = ref.tube_mesh(a, b, self.params.tube_radius)
            write_mesh(path, vertices, triangles, normals=normals)

    # }}}


# }}}

# {{{ the skinned application (book section 1.4)

SKINNED_ATTRACTION_DTYPE = np.dtype(
    [("position", "<f4", 3), ("bone", "<i4"), ("nearest", "<i4"), ("found", "<u4"), ("active", "<u4")]
)
"""Mirror of SkinnedAttraction (28 bytes)."""
SKINNED_NODE_DTYPE = np.dtype(
    [
        ("position", "<f4", 3),
        ("animated", "<f4", 3),
        ("index0", "<i4"),
        ("t", "<f4"),
        ("offset", "<f4"),
        ("mass", "<f4"),
        ("from", "<i4"),
        ("active", "<u4"),
    ]
)
"""Mirror of SkinnedNode (48 bytes)."""
SKINNED_CANDIDATE_DTYPE = np.dtype([("position", "<f4", 3), ("node", "<i4"), ("bone", "<i4")])
"""Mirror of SkinnedCandidate (20 bytes)."""


@functools.lru_cache(maxsize=4)
def figure_cloud(resolution: int, sample_distance: float, tries: int, seed: int) -> np.ndarray:
    """Attraction points filling the procedural figure at rest (VolumeSampler: voxels, then Poisson samples, those
    outside the surface dropped), and the voxel unit. Cached: the book bakes this into an asset once."""
    figure = skinned_figure.Figure()
    vertices, triangles, _ = figure.mesh()
    volume = skinned_figure.voxelize(vertices, triangles, resolution)
    points = skinned_figure.poisson_volume(volume, np.random.default_rng(seed), sample_distance, tries)
    inside = skinned_figure.inside_mesh(points, vertices, triangles, figure.components())
    return points[inside], volume.unit


@dataclass(frozen=True)
class SkinnedParams(BaseParams):
    resolution: int = param(100, 8, 256)
    """Voxels along the figure's largest extent (VolumeSampler window: resolution; the book's asset: 100)."""
    sample_distance: float = param(1.0, 1.0, 4.0)
    """Smallest distance between attraction points, voxels (VolumeSampler: r)."""
    tries: int = param(8, 1, 64)
    """Darts thrown around a sample before it is retired (VolumeSampler's Poisson sampling)."""
    seed_count: int = param(6, 1, 256)
    """Initial nodes on random attraction points (book: seedCount)."""
    unit_scale: float = param(2.5, 1.0, 10.0)
    """Distance unit = voxel size x unit_scale (book: unitScale)."""
    influence_distance: float = param(1.91, 0.0, lo_open=True)
    """Influence distance in units (book scene: influenceDistance)."""
    growth_distance: float = param(0.573, 0.0, lo_open=True)
    """Growth distance in units (book scene: growthDistance)."""
    kill_distance: float = param(0.398, 0.0, lo_open=True)
    """Kill distance in units (book scene: killDistance)."""
    growth_speed: float = param(22.0, 0.0, lo_open=True)
    """t grows by dt * growth_speed * mass per step, 1/s (book: growthSpeed)."""
    mass_min: float = param(0.25, 0.0, lo_open=True)
    """Lower bound of the growth-speed factor (book: massMin)."""
    mass_max: float = param(1.0, 0.0, lo_open=True)
    """Upper bound of the growth-speed factor (book: massMax)."""
    frame: int = param(1, 1, 60)
    """Run the algorithm every `frame` steps (book: frame)."""
    iterations: int = param(1, 1, 5)
    """Algorithm steps per run (book: iterations)."""
    repeat_guard: bool = False
    """A node does not emit its last candidate again, nor one on itself (ugpcl; off = the book)."""
    node_capacity: int = param(0, 0, 1 << 24)
    """Node slots (0: one per attraction, as the book)."""
    anim_time: float = param(0.0, 0.0)
    """Animation clock at reset, s of the clip."""
    anim_speed: float = param(0.35, 0.0)
    """Clip seconds per second (book scene: Animator speed 0.35)."""
    anim_period: float = param(2.4, 0.1)
    """Length of the dance loop, clip seconds."""
    animate: bool = True
    """Play the animation (false: frozen at the current clip time). Growth never depends on it."""
    tube_radius: float = param(0.0053, 0.0, lo_open=True)
    """Tube radius, figure units (book: _Thickness 0.01 on a 3.4-unit character; this figure is 1.8 tall)."""
    mesh_kind: str = param("tubes", choices=("tubes", "lines"))
    """What --mesh writes (at the current, animated pose)."""

    def check(self) -> None:
        if self.mass_min > self.mass_max:
            raise ValueError(f"mass_min must be <= mass_max, got {self.mass_min} > {self.mass_max}")


class SkinnedSimulation(Simulation):
    """The book's SkinnedSpaceColonization.cs on the procedural figure: growth in bind space, nodes skinned by their
    one bone every step (Animate)."""

    Params = SkinnedParams
    live_params = frozenset(
        {
            "influence_distance",
            "growth_distance",
            "kill_distance",
            "growth_speed",
            "mass_min",
            "mass_max",
            "frame",
            "iterations",
            "repeat_guard",
            "anim_speed",
            "anim_period",
            "animate",
            "tube_radius",
            "mesh_kind",
        }
    )
    program_stem = "space_colonization_skinned"

    def reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program(self.program_stem)
        key = (p.resolution, p.sample_distance, p.tries, self.seed)
        if getattr(self, "figure_key", None) != key:  # the book samples the volume and runs SetupSkin once
            self._build_figure(key)
        self.figure = skinned_figure.Figure(period=p.anim_period)
        self.unit = self.voxel_unit * p.unit_scale  # book: unitDistance = volume.unit * unitScale
        self.capacity = p.node_capacity or self.count
        self.nodes = rt.zeros(self.capacity, SKINNED_NODE_DTYPE)
        self.node_pool = Pool(rt, self.capacity, np.int32, "node_pool")
        self.candidates = Pool(rt, self.capacity, SKINNED_CANDIDATE_DTYPE, "candidates")
        self.edges = Pool(rt, 2 * self.capacity, EDGE_DTYPE, "edges")
        self.last_candidate = rt.zeros(self.capacity, cltypes.float4)
        self.setup_attractions()
        rng = np.random.default_rng(self.seed)
        seeds = self.cloud[rng.integers(0, self.count, p.seed_count)]
        self.setup()
        self.seed_nodes(seeds)
        self.nodes_count, self.edges_count = self.node_pool.count(), 0
        self.time, self.steps, self.frame_index = 0.0, 0, 0
        self.last_growth_step, self.last_connect = 0, 0
        self.anim_time = p.anim_time
        self.book_step(0.0)
        self.animate()

    def _build_figure(self, key) -> None:
        rt = self.runtime
        cloud, self.voxel_unit = figure_cloud(*key)
        self.figure_key = key
        self.cloud = cloud
        self.count = len(cloud)
        records = np.zeros(self.count, SKINNED_ATTRACTION_DTYPE)
        records["position"], records["bone"], records["nearest"], records["active"] = cloud, -1, -1, 1
        self.attractions = rt.to_device(records)
        vertices, self.mesh_triangles, self.mesh_bone = skinned_figure.Figure().mesh()
        self.mesh_vertices = vertices
        self.setup_skin(vertices, self.mesh_bone)
        self.bind_poses = skinned_figure.Figure().bind_poses()
        self.bind_pose_buffer = rt.to_device(self.bind_poses.astype(np.float32).reshape(-1))
        self.bone_matrix_buffer = rt.zeros(self.bind_poses.size, np.float32)

    # {{{ kernels, in the book's order

    def setup_skin(self, vertices: np.ndarray, bones: np.ndarray) -> None:
        """SetupSkin: each attraction takes the bone of its nearest mesh vertex."""
        rt = self.runtime
        vertex_buffer = rt.to_device(np.ascontiguousarray(vertices, np.float32).reshape(-1))
        bone_buffer = rt.to_device(np.ascontiguousarray(bones, np.int32))
        self._launch(
            "SetupSkin",
            self.count,
            self.attractions.data,
            np.int32(self.count),
            vertex_buffer.data,
            bone_buffer.data,
            np.int32(len(vertices)),
        )
        rt.finish()  # the temporary buffers go out of scope (the book's `using` block)

    def setup_attractions(self) -> None:
        """SetupAttractions: every attraction live again, nothing found (the cloud and its bones are kept)."""
        self._launch("SetupAttractions", self.count, self.attractions.data, np.int32(self.count))

    def seed_nodes(self, seeds: np.ndarray) -> None:
        """Seed: as the plain kernel, plus the bone of the nearest attraction."""
        p = self.params
        seeds = np.ascontiguousarray(seeds, np.float32).reshape(-1, 3)
        buffer = self.runtime.to_device(seeds.reshape(-1))
        n = min(len(seeds), self.node_pool.count())
        self._launch(
            "Seed",
            n,
            buffer.data,
            np.int32(n),
            self.attractions.data,
            np.int32(self.count),
            self.nodes.data,
            self.node_pool.counter.data,
            self.node_pool.items.data,
            np.float32(p.mass_min),
            np.float32(p.mass_max),
        )

    def search(self) -> None:
        """Search (bind space; the skinned kernels keep the book's all-pairs loops)."""
        p = self.params
        self._launch(
            "Search",
            self.count,
            self.attractions.data,
            np.int32(self.count),
            self.nodes.data,
            np.int32(self.capacity),
            np.float32(p.influence_distance * self.unit),
        )

    def attract(self) -> None:
        """Attract: candidates carry the bone of the nearest attraction that pulls their node."""
        p = self.params
        self.candidates.set_count(0)
        self._launch(
            "Attract",
            self.capacity,
            self.attractions.data,
            np.int32(self.count),
            self.nodes.data,
            np.int32(self.capacity),
            np.float32(p.growth_distance * self.unit),
            np.int32(p.repeat_guard),
            self.last_candidate.data,
            self.candidates.counter.data,
            self.candidates.items.data,
            np.int32(self.capacity),
        )

    def remove(self) -> None:
        """Remove (bind space)."""
        p = self.params
        self._launch(
            "Remove",
            self.count,
            self.attractions.data,
            np.int32(self.count),
            self.nodes.data,
            np.int32(self.capacity),
            np.float32(p.kill_distance * self.unit),
        )

    def animate(self, bone_matrices: np.ndarray | None = None) -> None:
        """Animate: animated = (bone matrix @ bind pose) @ (position, 1) per live node, with the figure's pose at
        the current clip time unless `bone_matrices` (B, 4, 4) are given (the book reads them from the Animator)."""
        if bone_matrices is None:
            bone_matrices = self.bone_matrices()
        self.bone_matrix_buffer.set(np.ascontiguousarray(bone_matrices, np.float32).reshape(-1))
        self._launch(
            "Animate",
            self.capacity,
            self.nodes.data,
            np.int32(self.capacity),
            self.bind_pose_buffer.data,
            self.bone_matrix_buffer.data,
            np.int32(len(self.bind_poses)),
        )

    # }}}

    def bone_matrices(self) -> np.ndarray:
        """Bone world matrices (B, 4, 4) at the current clip time."""
        return self.figure.pose(self.anim_time)

    def step(self, dt: float | None = None) -> None:
        dt = check_dt(dt, self.default_dt)
        super().step(dt)  # growth, in bind space
        if self.params.animate:
            self.anim_time += dt * self.params.anim_speed
        self.animate()

    def state(self) -> dict[str, np.ndarray]:
        out = super().state()
        nodes, attractions = self.read_nodes(), self.read_attractions()
        out.update(
            node_animated=np.ascontiguousarray(nodes["animated"]),
            node_bone=nodes["index0"].copy(),
            attraction_bone=attractions["bone"].copy(),
            bind_poses=self.bind_poses.astype(np.float32),
            bone_matrices=self.bone_matrices().astype(np.float32),
            mesh_vertices=self.mesh_vertices.astype(np.float32),
            mesh_triangles=self.mesh_triangles.astype(np.int32),
            mesh_bone=self.mesh_bone.astype(np.int32),
            anim_time=np.float32(self.anim_time),
        )
        return out

    def stats(self) -> dict:
        return {**super().stats(), "clip time": round(self.anim_time, 3)}

    def grown_segments(self) -> tuple[np.ndarray, np.ndarray]:
        """(a, b') per live edge at the animated pose (the skinned scene exports what it shows)."""
        nodes, edges = self.read_nodes(), self.read_edges()
        a = nodes["animated"][edges["a"]].astype(np.float64)
        b = nodes["animated"][edges["b"]].astype(np.float64)
        return a, a + (b - a) * nodes["t"][edges["b"]][:, None]


# }}}

# {{{ the blog's CPU version


CROWN_CLOUDS = ((75.0, 50.0), (90.0, 75.0), (100.0, 90.0))
"""(outer, inner) radius of the blog demo's three crown clouds, appended one after the other."""


@dataclass(frozen=True)
class CpuParams(BaseParams):
    crown_points: tuple[int, int, int] = param((800, 300, 50), 0, 1 << 20)
    """Points of the three crown clouds (blog demo: generateAttractionPoints(800, 75, 50 ...), (300, 90, 75 ...),
    (50, 100, 90 ...))."""
    aspect: float = param(2.0, 0.0, lo_open=True)
    """Vertical stretch of the crown clouds (blog: pAspect)."""
    offset_y: float = 30.0
    """Height of the crown clouds' base (blog: pOffsetY)."""
    trunk_height: float = 30.0
    """The trunk: growBranch(0, (0, trunk_height, 0)) before the first iteration."""
    max_distance: float = param(100.0, 0.0, lo_open=True)
    """A point pulls its closest vertex within this distance (blog: pMaxDistance, the paper's d_i)."""
    branch_size: float = param(2.0, 0.0, lo_open=True)
    """Length of every new branch (blog: pBranchSize, the paper's D)."""
    cut_off_distance: float = param(10.0, 0.0, lo_open=True)
    """A point this close to its closest vertex is removed (blog: pCutOffDistance, the paper's d_k)."""
    bias: tuple[float, float, float] = (0.1, 0.2, 0.0)
    """Added to every new branch after the normalised step (blog: pBias)."""
    root_points: int = param(100, 0, 1 << 20)
    """Points of the roots cloud generated when the crown is done (blog demo: 100, 50, 10, 0.2, -3)."""
    root_outer: float = param(50.0, 0.0, lo_open=True)
    """Outer radius of the roots cloud."""
    root_inner: float = param(10.0, 0.0)
    """Inner radius of the roots cloud."""
    root_aspect: float = param(0.2, 0.0, lo_open=True)
    """Vertical stretch of the roots cloud."""
    root_offset_y: float = -3.0
    """Base height of the roots cloud."""
    root_max_distance: float = param(25.0, 0.0, lo_open=True)
    """pMaxDistance of the roots stage."""
    root_branch_size: float = param(2.0, 0.0, lo_open=True)
    """pBranchSize of the roots stage."""
    root_cut_off_distance: float = param(5.0, 0.0, lo_open=True)
    """pCutOffDistance of the roots stage."""
    root_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """pBias of the roots stage."""
    clear_leftovers: bool = False
    """Drop the crown's stuck points before the roots stage (blog: pClear false keeps them)."""
    repeat_guard: bool = False
    """A vertex does not grow to the point it grew to last time (ugpcl). Without it a trapped vertex regrows the
    same point every iteration and the stage ends by ugpcl's stall detector."""
    max_iterations: int = param(2000, 1, 1 << 20)
    """Iterations per stage at most (ugpcl)."""

    def check(self) -> None:
        if self.root_inner >= self.root_outer:
            raise ValueError(f"root_inner must be < root_outer, got {self.root_inner} >= {self.root_outer}")


class CpuSimulation(BaseSimulation):
    """The blog's tree: one doIteration per step, the crown stage, then the roots stage, then nothing."""

    Params = CpuParams
    history = ("vertex_count", "point_count")

    def reset(self) -> None:
        p = self.params
        self.rng = np.random.default_rng(self.seed)
        self.tree = ref.BlogTree()
        self.tree.grow_branch(0, (0.0, p.trunk_height, 0.0))
        for count, (outer, inner) in zip(p.crown_points, CROWN_CLOUDS, strict=True):
            self.tree.add_points(ref.hemisphere_cloud(count, outer, inner, p.aspect, p.offset_y, self.rng))
        self.stage = 0
        self.stage_iterations = np.zeros(2, np.int32)
        self.stalled = np.zeros(2, bool)
        self.root_stage_first_vertex = -1
        self.time, self.steps = 0.0, 0

    @property
    def finished(self) -> bool:
        return self.stage >= 2

    def do_iteration(self) -> None:
        """One doIteration of the current stage; ends the stage when no points are left or nothing new grew."""
        p = self.params
        if self.finished:
            return
        if self.stage == 0:
            args = (p.max_distance, p.branch_size, p.cut_off_distance, p.bias)
        else:
            args = (p.root_max_distance, p.root_branch_size, p.root_cut_off_distance, p.root_bias)
        left, grown, all_repeats = self.tree.do_iteration(*args, repeat_guard=p.repeat_guard)
        self.stage_iterations[self.stage] += 1
        stuck = grown == 0 or all_repeats  # nothing new can ever grow: the same iteration would repeat forever
        if not left or stuck or self.stage_iterations[self.stage] >= p.max_iterations:
            self.stalled[self.stage] = left
            self._next_stage()

    def _next_stage(self) -> None:
        p = self.params
        self.stage += 1
        if self.stage == 1:  # the blog's second cloud: roots around the base
            self.root_stage_first_vertex = len(self.tree.vertices)
            roots = ref.hemisphere_cloud(
                p.root_points, p.root_outer, p.root_inner, p.root_aspect, p.root_offset_y, self.rng
            )
            self.tree.add_points(roots, clear=p.clear_leftovers)

    def step(self, dt: float | None = None) -> None:
        dt = check_dt(dt, self.default_dt)
        self.do_iteration()
        self._advance(dt)

    def state(self) -> dict[str, np.ndarray]:
        return {
            "vertices": self.tree.vertices.copy(),
            "segments": np.asarray(self.tree.segments, np.int32).reshape(-1, 2),
            "attraction_position": self.tree.points.copy(),
            "stage_iterations": self.stage_iterations.copy(),
            "stalled": self.stalled.copy(),
            "root_stage_first_vertex": np.int32(self.root_stage_first_vertex),
            "vertex_count": np.int32(len(self.tree.vertices)),
            "point_count": np.int32(len(self.tree.points)),
        }

    def stats(self) -> dict:
        return {
            **super().stats(),
            "stage": ("crown", "roots", "done")[self.stage],
            "vertices": len(self.tree.vertices),
            "points left": len(self.tree.points),
            "iterations (crown, roots)": tuple(int(i) for i in self.stage_iterations),
            "stalled (crown, roots)": tuple(bool(s) for s in self.stalled),
        }

    def export_mesh(self, path) -> None:
        """--mesh: OBJ polylines of the segments (blog units)."""
        segments = np.asarray(self.tree.segments, np.int64).reshape(-1, 2)
        write_mesh(path, self.tree.vertices, lines=segments)


# }}}

# {{{ benchmark


def sphere_count(side: int) -> int:
    """Attractions of the book's sphere cloud of this side (the jitter never changes the count)."""
    g = (np.arange(side) / (side - 1) - 0.5) ** 2
    return int(((g[:, None, None] + g[None, :, None] + g[None, None, :]) < 0.25).sum())


def side_for(size: int) -> int:
    """The sphere side whose cloud holds the number of attractions nearest to `size` (about pi/6 side^3)."""
    guess = round((6.0 * size / math.pi) ** (1.0 / 3.0))
    return min(range(max(4, guess - 2), guess + 3), key=lambda side: abs(sphere_count(side) - size))


def grow_fully(sim: Simulation, max_steps: int) -> tuple[int, float, int]:
    """Step until nothing can grow any more: the pool is empty, or no node was made for as long as the slowest node
    needs to mature. Returns (steps run, seconds, step of the last growth)."""
    p = sim.params
    patience = math.ceil(1.0 / (sim.default_dt * p.growth_speed * p.mass_min)) + 1
    queue = sim.runtime.queue
    queue.finish()
    start = time.perf_counter()
    while sim.steps < max_steps:
        sim.step()
        if sim.nodes_count == 0 or sim.steps - sim.last_growth_step > patience:
            break
    queue.finish()
    return sim.steps, time.perf_counter() - start, sim.last_growth_step


def bench(runtime, sizes=None) -> list[dict]:
    """Space colonization (book scene values, sphere cloud, repeat guard on so that growth ends): seconds and steps
    until the tree is fully grown, steps/s over that growth, and the uniform grid's speed-up over the book's
    all-pairs loops (all-pairs is skipped where one tree would take minutes)."""
    sizes = sizes or ([4096, 16384, 65536, 262144] if runtime.is_gpu else [1736, 4096, 16384])
    all_pairs_limit = 70000 if runtime.is_gpu else 20000
    rows = []
    for size in sizes:
        side = side_for(size)
        seconds = {}
        for search in ("all_pairs", "grid"):
            sim = Simulation(runtime, Params(side=side, search=search, repeat_guard=True), seed=0)
            if search == "all_pairs" and sim.count > all_pairs_limit:
                rows.append(
                    {
                        "A": sim.count,
                        "search": search,
                        "steps": "-",
                        "s to grow": "-",
                        "steps/s": "-",
                        "nodes": "-",
                        "speed-up": "-",
                    }
                )
                continue
            steps, secs, last = grow_fully(sim, 3000)
            seconds[search] = secs
            speed_up = seconds["all_pairs"] / secs if search == "grid" and "all_pairs" in seconds else "-"
            rows.append(
                {
                    "A": sim.count,
                    "search": search,
                    "steps": last,
                    "s to grow": secs,
                    "steps/s": steps / secs,
                    "nodes": sim.capacity - sim.nodes_count,
                    "speed-up": speed_up,
                }
            )
    return rows


# }}}


SCENES = [
    Scene(
        "space_colonization",
        Simulation,
        "GPU space colonization: a tree grows through a sphere of attraction points (vol.4 ch.1)",
        preview={"steps": 240},
    ),
    Scene(
        "space_colonization_tubes",
        Simulation,
        "The same tree drawn as capsules by a geometry shader (vol.4 ch.1, TubularEdge scene)",
        {"render": "tubes"},
        preview={"steps": 240},
    ),
    Scene(
        "space_colonization_skinned",
        SkinnedSimulation,
        "Space colonization inside a dancing figure: nodes skinned by their bone (vol.4 ch.1 section 1.4)",
        view="SkinnedView",
        preview={"steps": 300},
    ),
    Scene(
        "space_colonization_cpu",
        CpuSimulation,
        "The blog's CPU space colonization: crown, then roots (vol.4 ch.1 + B. Olij 2014)",
        view="CpuView",
        preview={"steps": 300},
    ),
]
