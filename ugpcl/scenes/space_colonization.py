"""GPU space colonization: a tree grows through a sphere of attraction points (Unity Graphics Programming vol.4 ch.1,
"GPU-Based Space Colonization Algorithm": the Line and TubularEdge scenes; docs/chapters/12-space-colonization.md).

Kernel order (clkernels/space_colonization.cl): ``reset`` runs Setup (every node slot into the pool), Seed
(``seed_count`` nodes on random attraction points) and one step; each ``step`` runs, while the node pool has free
slots, Search (nearest node of every attraction within the influence distance), Attract (every grown node pulled by
an attraction proposes a candidate one growth distance along the mean unit vector), ConnectCount and Connect
(candidates become nodes joined by edges; never more than the free slots) and reads the pool and edge counts back,
Remove (attractions within the kill distance of a node die); then always Grow (t += dt * growth_speed * mass). A
node branches only once t reaches 1, which is also what animates the edges in the view.

Speed (ugpcl; the same results): one read-back per Step, the node pool, edge and connect counters in one wait (the
book's CopyNodesCount, CopyEdgesCount); the candidate counter is cleared by an enqueued fill and Connect's count
(book: Mathf.Min(nodesCount, CopyCount) on the host) is taken on the device by ConnectCount. GPUs (and Oclgrind) run
the all-pairs loops as Search_tiled, Attract_tiled and Remove_tiled (``tiles``), which read the records through
__local tiles in the book's order; CPU devices run the book's loops.

Scenes: ``space_colonization`` (Line scene) and ``space_colonization_tubes`` (TubularEdge scene). The chapter's
other stems: ``space_colonization_skinned`` (the book's section 1.4 application, which reuses ``GrowthParams`` and
``GrowthSimulation`` from here) and ``space_colonization_cpu`` (the blog's CPU algorithm).

Pace: a ``step`` is one frame of the book's Update, which runs ``iterations`` Steps every ``frame`` frames. The
scenes run 5 Steps a frame (the inspector's largest ``iterations``) with growth_speed 44 (twice the scene's 22;
``SHORT_RUN_PACE``), so that a 10-step run shows the grown tree, which the book's pace reaches after about 100
frames; the Params class keeps the book's values, and ``--set iterations=1 growth_speed=22`` is the book's pace.

Node slots, one rule on the host: ``capacity`` slots in all; ``free_slots`` of them wait in the node pool (the book's
``nodesCount``, read back with CopyCount); ``live_nodes = capacity - free_slots`` are active; ``live_edges`` edges
exist. Setup puts slot 0 on top of the pool (the book appends in atomic order) and no node is freed during a run, so
the live nodes are slots [0, live_nodes) (``node_slot_end``), the prefix the views read back (``live_records``).
The ``.npz`` keeps the chapter page's names: ``nodes_free`` (free slots), ``node_count`` (live nodes),
``edges_count``. On a GPU the sphere view's count of active attractions is taken on the device
(CountActiveAttractions).

Differences from the book: attractions closer than 1e-12 to their node are skipped in Attract (the book's seeds sit
on attraction points and make NaN nodes); ``repeat_guard`` (on by default; ``--set repeat_guard=false`` is the book)
stops a node emitting its last candidate again or one on itself (cancelling attractions otherwise drain the pool with
zero-length copies); ``search=grid`` replaces the all-pairs loops of Search, Attract and Remove by uniform-grid
lookups with the same results; the attractions are stored sorted by grid cell (a permutation of the book's cloud) so
that both modes sum Attract's unit vectors in the same order; the book's Connect rewrites the parent unchanged (left
out).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..buffers import Pool
from ..geometry import space_colonization as geo
from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..grid import LOCAL_SIZE as GRID_LOCAL_SIZE
from ..grid import UniformGrid
from ..scene import Animation, AtScale, Scene, param
from ..scene import Params as BaseParams
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


# {{{ what the sphere and the skinned scenes share


@dataclass(frozen=True)
class GrowthParams(BaseParams):
    """The book's SpaceColonization component, as the sphere and the skinned scenes share it. Distances are in units
    of the scene's ``unit`` (book: unitDistance)."""

    seed_count: int = param(6, 1, 256)
    """Initial nodes, placed on random attraction points (book: seedCount)."""
    influence_distance: float = param(1.14, 0.0, 1e3, lo_open=True, live=True)
    """An attraction pulls its nearest node within this distance, in units of `unit` (book: influenceDistance).
    Up to 1e3 units: far past the cloud; squared in float32."""
    growth_distance: float = param(0.597, 0.0, 1e3, lo_open=True, live=True)
    """Length of one new branch, in units of `unit` (book: growthDistance).
    Up to 1e3 units: far past the cloud; squared in float32."""
    kill_distance: float = param(0.484, 0.0, 1e3, lo_open=True, live=True)
    """An attraction this close to any node is removed, in units of `unit` (book: killDistance).
    Up to 1e3 units: far past the cloud; squared in float32."""
    growth_speed: float = param(22.0, 0.0, 1e4, lo_open=True, live=True)
    """t grows by dt * growth_speed * mass per step, 1/s (book: growthSpeed).
    Up to 1e4: dt * growth_speed * mass stays finite."""
    mass_min: float = param(0.25, 0.0, 1e3, lo_open=True, live=True)
    """Lower bound of the per-node growth-speed factor (book: massMin). Up to 1e3, as growth_speed."""
    mass_max: float = param(1.0, 0.0, 1e3, lo_open=True, live=True)
    """Upper bound of the per-node growth-speed factor (book: massMax). Up to 1e3, as growth_speed."""
    frame: int = param(1, 1, 60, live=True)
    """Run the algorithm every `frame` steps (book: frame)."""
    iterations: int = param(1, 1, 5, live=True)
    """Algorithm steps per run, each with the same dt (book: iterations)."""
    repeat_guard: bool = param(True, live=True)
    """A node does not emit the candidate it emitted last time, nor one that sits on the node (ugpcl, on by
    default). false = the book: cancelling attractions put a candidate on its node, and zero-length copies of that
    node drain the pool."""
    node_capacity: int = param(0, 0, 1 << 24)
    """Node slots (0: one per attraction, as the book). Fewer slots show the pool running dry."""
    tube_radius: float = param(0.0055, 0.0, 100.0, lo_open=True, live=True)
    """Tube radius of the view and of --mesh, in the attraction cloud's units (book: _Thickness; 0.033 at object
    scale 6 in the TubularEdge scene, 0.01 on the skinned scene's 3.4-unit character; both scaled to ours).
    Up to 100: far wider than any cloud."""
    mesh_kind: str = param("tubes", choices=("tubes", "lines"), live=True)
    """What --mesh writes: closed capsules per grown edge, or OBJ polylines (`l`)."""

    limits = ("mass_min <= mass_max",)

    def check(self) -> None:
        if self.mass_min > self.mass_max:
            raise self.broken(self.limits[0])


class GrowthSimulation(BaseSimulation):
    """The host side of the book's Step that the sphere and the skinned scenes share: node, candidate and edge
    pools, Setup, Search, Attract, Connect, Remove, Grow, the state and the mesh. A scene's ``_reset`` builds its
    program, attraction buffer and ``unit``, calls ``_allocate_nodes`` and ends with ``_start(seeds)``."""

    Params = GrowthParams
    history = ("node_count", "active_attraction")
    attraction_dtype: ClassVar[np.dtype] = ATTRACTION_DTYPE
    node_dtype: ClassVar[np.dtype] = NODE_DTYPE
    candidate_dtype: ClassVar[np.dtype] = CANDIDATE_DTYPE
    drawn_position: ClassVar[str] = "position"
    """The node field the view draws and --mesh exports (the skinned scene: ``animated``)."""

    program: object
    unit: float
    """Distance unit of every *_distance parameter (book: unitDistance)."""
    attractions: object
    attraction_count: int
    capacity: int
    """Node slots in all."""
    free_slots: int
    """Node slots waiting in the pool, as last read (book: nodesCount, CopyNodesCount)."""
    live_edges: int
    """Edges made so far, as last read (book: edgesCount, CopyEdgesCount)."""
    tiles: bool
    """The all-pairs loops of Search, Attract and Remove run as their _tiled kernels (read through __local tiles,
    the same results): set at reset on GPUs and Oclgrind (which checks them); CPU devices run the book's loops, which
    PoCL runs faster. The tests set it to compare the two."""

    loaded_slot_end: int
    """One past the highest active slot ``load_state`` put in (0 after a reset)."""

    @property
    def live_nodes(self) -> int:
        """Active nodes: the slots not in the pool."""
        return self.capacity - self.free_slots

    @property
    def node_slot_end(self) -> int:
        """Every active node is in slots [0, node_slot_end). The pool hands out its lowest free slot first (Setup,
        ``load_state``), so after a reset the live nodes are exactly [0, live_nodes); after ``load_state`` the free
        slots below its highest active one fill first, then the slots above it, one after another."""
        return max(self.loaded_slot_end, self.live_nodes)

    # {{{ setup

    def _allocate_nodes(self, capacity: int) -> None:
        rt = self.runtime
        self.tiles = rt.is_oclgrind or not rt.device.type & cl.device_type.CPU
        self.capacity = int(capacity)
        self.nodes = rt.zeros(self.capacity, self.node_dtype)
        self.node_pool = Pool(rt, self.capacity, np.int32, "node_pool")
        self.candidates = Pool(rt, self.capacity, self.candidate_dtype, "candidates")  # <= one per node per step
        self.edges = Pool(rt, 2 * self.capacity, EDGE_DTYPE, "edges")  # book: count * 2
        self.last_candidate = rt.zeros(self.capacity, cltypes.float4)  # repeat_guard: (last candidate, emitted)
        self.connect_count = rt.zeros(1, np.int32)  # ConnectCount -> Connect: min(free slots, candidates)
        self.read_back = np.zeros(3, np.int32)  # free slots, edges, connect count: the one read of a Step

    def _start(self, seeds: np.ndarray) -> None:
        """Setup, Seed, then the book's Start ends with Step(0): the seeds branch at once."""
        self.setup()
        self.seed_nodes(seeds)
        self.free_slots = self.node_pool.count()  # book: CopyNodesCount (A - seeds)
        self.live_edges = 0
        self.loaded_slot_end = 0
        self.frame_index = 0
        self.last_growth_step, self.last_connect = 0, 0
        self.book_step(0.0)

    def _nodes_changed(self) -> None:
        """Called when node records change (the sphere scene's node grid goes stale)."""

    def _seed_lookup_args(self) -> tuple:
        """Seed's arguments between (seeds, seed_count) and nodes: none here; the skinned Seed reads the attractions."""
        return ()

    # }}}

    # {{{ kernels, in the book's order

    def setup(self) -> None:
        """Setup: every node slot into the pool, slot 0 on top (Setup writes the entries, the host the count), every
        node inactive."""
        self.node_pool.set_count(self.capacity)
        self.program.kernel("Setup").over(
            self.capacity, LOCAL_SIZE, self.nodes.data, np.int32(self.capacity), self.node_pool.items.data
        )

    def seed_nodes(self, seeds: np.ndarray) -> None:
        """Seed (named so because ``seed`` is the random seed): one grown node per seed position."""
        p = self.params
        seeds = np.ascontiguousarray(seeds, np.float32).reshape(-1, 3)
        buffer = self.runtime.to_device(seeds.reshape(-1))
        n = min(len(seeds), self.node_pool.count())  # never more consumers than free slots
        self.program.kernel("Seed").over(
            n,
            LOCAL_SIZE,
            buffer.data,
            np.int32(n),
            *self._seed_lookup_args(),
            self.nodes.data,
            self.node_pool.counter.data,
            self.node_pool.items.data,
            np.float32(p.mass_min),
            np.float32(p.mass_max),
        )
        self._nodes_changed()

    def search(self) -> None:
        """Search: nearest active node within the influence distance of every active attraction."""
        self._attractions_to_nodes("Search", self.params.influence_distance * self.unit)

    def attract(self) -> None:
        """Attract: the candidate counter is cleared, then every grown, pulled node appends one candidate."""
        self._clear_candidates()
        self.program.kernel(self._all_pairs("Attract")).over(
            self.capacity,
            LOCAL_SIZE,
            self.attractions.data,
            np.int32(self.attraction_count),
            self.nodes.data,
            np.int32(self.capacity),
            *self._attract_tail(),
        )

    def _all_pairs(self, kernel: str) -> str:
        """The book's all-pairs kernel, or its _tiled variant where ``tiles`` says so."""
        return f"{kernel}_tiled" if self.tiles else kernel

    def _clear_candidates(self) -> None:
        """The book's SetCounterValue(0) on the candidates (count and refused), enqueued: the host does not wait."""
        counter = self.candidates.counter
        cl.enqueue_fill_buffer(self.runtime.queue, counter.data, np.int32(0), 0, counter.nbytes)

    def _attract_tail(self) -> tuple:
        """Attract's arguments after the node count (the same in every Attract variant)."""
        p = self.params
        return (
            np.float32(p.growth_distance * self.unit),
            np.int32(p.repeat_guard),
            self.last_candidate.data,
            self.candidates.counter.data,
            self.candidates.items.data,
            np.int32(self.capacity),
        )

    def connect(self) -> int:
        """ConnectCount and Connect: min(free slots, candidates) work-items, a count the device takes from the two
        counters itself, each turn a candidate into a node and an edge; Connect is dispatched over every candidate
        slot and the work-items past the count return. Then the one read of the Step (``_read_counts``). Returns the
        nodes made (the connect count)."""
        p = self.params
        program = self.program
        program.kernel("ConnectCount").over(
            1, 1, self.node_pool.counter.data, self.candidates.counter.data, self.connect_count.data
        )
        program.kernel("Connect").over(
            self.candidates.capacity,
            LOCAL_SIZE,
            self.nodes.data,
            self.node_pool.counter.data,
            self.node_pool.items.data,
            self.candidates.counter.data,
            self.candidates.items.data,
            self.edges.counter.data,
            self.edges.items.data,
            np.int32(self.edges.capacity),
            self.connect_count.data,
            np.float32(p.mass_min),
            np.float32(p.mass_max),
        )
        made = self._read_counts()
        self.last_connect = made
        if made:
            self._nodes_changed()
        return made

    def _read_counts(self) -> int:
        """The Step's one read-back: free slots and edges (book: CopyNodesCount, CopyEdgesCount, which it reads after
        Remove; only Connect changes them) and Connect's count, three small copies and one wait. Sets
        ``free_slots`` and ``live_edges``, returns the connect count."""
        queue, out = self.runtime.queue, self.read_back
        cl.enqueue_copy(queue, out[0:1], self.node_pool.counter.data, is_blocking=False)
        cl.enqueue_copy(queue, out[1:2], self.edges.counter.data, is_blocking=False)
        cl.enqueue_copy(queue, out[2:3], self.connect_count.data, is_blocking=True)  # in order: all three are in
        self.free_slots, self.live_edges = int(out[0]), int(out[1])
        return int(out[2])

    def remove(self) -> None:
        """Remove: attractions within the kill distance of any active node (the new ones included)."""
        self._attractions_to_nodes("Remove", self.params.kill_distance * self.unit)

    def _attractions_to_nodes(self, kernel: str, radius: float) -> None:
        """Search and Remove: every active attraction visits every node slot within ``radius`` (the book's loops)."""
        self.program.kernel(self._all_pairs(kernel)).over(
            self.attraction_count,
            LOCAL_SIZE,
            self.attractions.data,
            np.int32(self.attraction_count),
            self.nodes.data,
            np.int32(self.capacity),
            np.float32(radius),
        )

    def grow(self, dt: float) -> None:
        """Grow: t = saturate(t + dt * growth_speed * mass) for every active node."""
        dT = np.float32(dt * self.params.growth_speed)
        self.program.kernel("Grow").over(self.capacity, LOCAL_SIZE, self.nodes.data, np.int32(self.capacity), dT)

    # }}}

    def book_step(self, dt: float) -> None:
        """The book's Step(dt): the algorithm while the pool has free slots, then Grow."""
        if self.free_slots > 0:  # book: do not run when the object pool is empty
            self.search()
            self.attract()
            made = self.connect()  # and CopyNodesCount, CopyEdgesCount: free_slots, live_edges
            self.remove()
            if made:
                self.last_growth_step = self.steps
        self.grow(dt)

    def _step(self, dt: float) -> None:
        p = self.params
        if self.frame_index % p.frame == 0:  # book: every `frame` frames, `iterations` steps
            for _ in range(p.iterations):
                self.book_step(dt)
        self.frame_index += 1

    # {{{ state

    def load_state(self, nodes: np.ndarray, attractions: np.ndarray | None = None) -> None:
        """Replace the node records (and the attractions, same count) by hand, for tests and experiments: the pool
        becomes the free slots in descending order (the top = the lowest free index, as after Setup), the edges are
        cleared."""
        if len(nodes) != self.capacity or (attractions is not None and len(attractions) != self.attraction_count):
            raise ValueError(f"load_state needs {self.capacity} nodes and {self.attraction_count} attractions")
        self.nodes.set(np.ascontiguousarray(nodes, self.node_dtype))
        if attractions is not None:
            self.attractions.set(np.ascontiguousarray(attractions, self.attraction_dtype))
        active = nodes["active"] != 0
        free = np.flatnonzero(~active).astype(np.int32)
        self.node_pool.fill(free[::-1])
        self.free_slots, self.live_edges = len(free), 0
        self.loaded_slot_end = int(np.flatnonzero(active)[-1]) + 1 if active.any() else 0
        self.edges.set_count(0)
        self.last_candidate.set(np.zeros(self.capacity, cltypes.float4))
        self._nodes_changed()

    def read_nodes(self) -> np.ndarray:
        return self.nodes.get()

    def read_attractions(self) -> np.ndarray:
        return self.attractions.get()

    def live_records(self) -> tuple[np.ndarray, np.ndarray]:
        """(node slots [0, node_slot_end), live edges) in the page-locked host copies of ``Runtime.read_back``, for
        a view to hand straight to GL (the next call overwrites them): every node an edge names, and no free slot
        past the last live one (at 2 M slots, 64 MB a frame)."""
        rt = self.runtime
        return rt.read_back(self.nodes, self.node_slot_end), rt.read_back(self.edges.items, self.live_edges)

    def read_edges(self) -> np.ndarray:
        """The live edges (book: the first edgesCount entries of the edge buffer)."""
        out = np.empty(self.live_edges, EDGE_DTYPE)
        if self.live_edges:
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
            "nodes_free": np.int32(self.free_slots),
            "edges_count": np.int32(self.live_edges),
            "node_count": np.int32(self.live_nodes),
            "active_attraction": np.int32((attractions["active"] != 0).sum()),
        }

    def stats(self) -> dict:
        attractions = self.read_attractions()
        return {
            **super().stats(),
            "attractions": self.attraction_count,
            "active attractions": int((attractions["active"] != 0).sum()),
            "live nodes": self.live_nodes,
            "free slots": self.free_slots,
            "edges": self.live_edges,
            "last growth at step": self.last_growth_step,
        }

    def grown_segments(self) -> tuple[np.ndarray, np.ndarray]:
        """(a, b') per live edge with b' = a + (b - a) * t_b: the branches as drawn (t grows the child's edge)."""
        nodes, edges = self.read_nodes(), self.read_edges()
        drawn = nodes[self.drawn_position]
        a = drawn[edges["a"]].astype(np.float64)
        b = drawn[edges["b"]].astype(np.float64)
        return a, a + (b - a) * nodes["t"][edges["b"]][:, None]

    def mesh(self) -> Mesh:
        """A closed capsule of tube_radius around every grown edge, as drawn: watertight, wound outwards."""
        vertices, normals, triangles = geo.tube_mesh(*self.grown_segments(), self.params.tube_radius)
        return Mesh(vertices, triangles, normals)

    def export_mesh(self, path) -> None:
        """--mesh: ``mesh()`` (mesh_kind=tubes) or the grown edges as line segments (lines; .obj or .glb)."""
        if self.params.mesh_kind == "tubes":
            write_mesh(path, self.mesh())
            return
        a, b = self.grown_segments()
        vertices = np.stack([a, b], axis=1).reshape(-1, 3)
        write_mesh(path, Mesh(vertices, np.zeros((0, 3))), lines=np.arange(len(vertices)).reshape(-1, 2))

    # }}}


# }}}

# {{{ the sphere scene


@dataclass(frozen=True)
class Params(GrowthParams):
    side: int = param(28, 4, 160)
    """Grid resolution of the attraction cloud: side^3 grid points, those inside the sphere kept (book: count)."""
    cloud: str = param("sphere", choices=("sphere", "hemisphere", "box"))
    """Shape of the attraction cloud: the book's sphere, the blog's hemisphere generator, or a filled cube."""
    search: str = param("all_pairs", choices=("all_pairs", "grid"), live=True)
    """Neighbour lookups of Search, Attract and Remove: the book's loops over every slot, or a uniform grid
    (cell = the larger of influence and kill distance): same results, far fewer distance tests."""
    render: str = param("lines", choices=("lines", "tubes"), live=True)
    """How the view draws the edges: additive lines (book: Line scene, Edge.shader) or capsules (TubularEdge scene)."""
    object_scale: float = param(6.0, 0.0, 1e4, lo_open=True, live=True)
    """Drawing scale of the cloud (book: the SpaceColonization object's transform), render only.
    Up to 1e4: float32 positions keep 1e-3."""

    @property
    def unit(self) -> float:
        """Distance unit: 2 / side (book: unitDistance), so finer clouds grow finer branches."""
        return 2.0 / self.side


def make_cloud(p: Params, rng: np.random.Generator) -> np.ndarray:
    if p.cloud == "sphere":
        return geo.sphere_cloud(p.side, rng)
    if p.cloud == "box":
        return geo.box_cloud(p.side, rng)
    # the blog's generator in cloud units: as many points as the sphere, a dome of radius 0.5 standing on y = -0.25
    n = len(geo.sphere_cloud(p.side, np.random.default_rng(0)))
    return geo.hemisphere_cloud(n, 0.5, 0.0, 1.0, -0.25, rng)


class NodeGrid(UniformGrid):
    """The uniform grid of the active nodes: NodeGridHash keys only the active slots (the rest get empty keys, which
    own no cell and sort last), then ``UniformGrid.sort`` as for any grid."""

    def build_active(self, program, nodes, slots: int) -> None:
        program.kernel("NodeGridHash").over(
            slots,
            GRID_LOCAL_SIZE,
            nodes.data,
            np.int32(slots),
            np.int32(slots),  # `padded`: the counting sort needs no power-of-two padding
            *self.geometry_args(),
            self.hash_keys,
        )
        self.sort(slots)


class Simulation(GrowthSimulation):
    """The book's SpaceColonization.cs on a sphere (or hemisphere, box) of attractions; Step per frame."""

    Params = Params
    count_on_device: bool
    """``count_active_attractions`` runs CountActiveAttractions (set at reset on GPUs and Oclgrind); CPU devices
    count on the host, where reading the flags costs less than a launch (PoCL, 3544 attractions: 0.04 ms against
    0.12). The tests set it to compare the two."""

    # {{{ setup

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program("space_colonization")
        rng = np.random.default_rng(self.seed)
        cloud = make_cloud(p, rng)
        seeds = cloud[rng.integers(0, len(cloud), p.seed_count)]  # book: attractions[Random.Range(0, count)]
        self.unit = p.unit
        self.attraction_count = len(cloud)
        records = np.zeros(self.attraction_count, ATTRACTION_DTYPE)
        records["position"], records["nearest"], records["active"] = cloud, -1, 1
        self.attractions = rt.to_device(records)
        self.active_count = rt.zeros(1, np.int32)  # CountActiveAttractions' sum
        self.count_on_device = rt.is_oclgrind or not rt.device.type & cl.device_type.CPU
        self.lower = cloud.min(axis=0) if len(cloud) else np.zeros(3)
        self.upper = cloud.max(axis=0) if len(cloud) else np.ones(3)
        self._allocate_nodes(p.node_capacity or len(cloud))
        self.grid_cell = 0.0
        self._sort_attractions_by_cell()
        self._start(seeds)

    def _grid_cell_size(self) -> float:
        p = self.params
        return max(p.influence_distance, p.kill_distance) * self.unit

    def _sort_attractions_by_cell(self) -> None:
        """Build the attraction and node grids for the current radii and store the attractions sorted by cell
        (device keys, so host and device agree on every cell). Nothing refers to attraction indices across steps
        (Search rewrites `nearest`), so the permutation changes no result."""
        rt, cell, n = self.runtime, self._grid_cell_size(), self.attraction_count
        self.grid_cell = cell
        self.attraction_grid = UniformGrid.covering(rt, max(n, 1), self.lower, self.upper + 1e-6, cell)
        self.node_grid = NodeGrid(rt, self.capacity, self.attraction_grid.origin, cell, self.attraction_grid.dims)
        self.attraction_grid.build(self.attractions, n, ATTRACTION_DTYPE.itemsize // 4, 0)
        order = (self.attraction_grid.sorted_keys() & np.uint64(0xFFFFFFFF)).astype(np.int64)
        self.attractions.set(self.attractions.get()[order])
        self.attraction_grid.build(self.attractions, n, ATTRACTION_DTYPE.itemsize // 4, 0)
        self.node_grid_stale = True

    def _nodes_changed(self) -> None:
        self.node_grid_stale = True

    def _node_grid(self) -> NodeGrid:
        if self.grid_cell < self._grid_cell_size():  # a radius grew past the cell: the 3x3x3 lookup would miss
            self._sort_attractions_by_cell()
        if self.node_grid_stale:
            self.node_grid.build_active(self.program, self.nodes, self.capacity)
            self.node_grid_stale = False
        return self.node_grid

    # }}}

    # {{{ the grid variants of Search, Attract and Remove

    def attract(self) -> None:
        """Attract; with ``search=grid`` each node visits the attraction-grid cells around it (Attract_grid)."""
        if self.params.search != "grid":
            super().attract()
            return
        self._clear_candidates()
        if self.grid_cell < self._grid_cell_size():
            self._sort_attractions_by_cell()
        grid = self.attraction_grid
        self.program.kernel("Attract_grid").over(
            self.capacity,
            LOCAL_SIZE,
            self.attractions.data,
            self.nodes.data,
            np.int32(self.capacity),
            *self._attract_tail(),
            *grid.geometry_args(),
            *grid.search_args(),
        )

    def _attractions_to_nodes(self, kernel: str, radius: float) -> None:
        """Search and Remove; with ``search=grid`` each attraction visits the node-grid cells around it
        (``<kernel>_grid``)."""
        if self.params.search != "grid":
            super()._attractions_to_nodes(kernel, radius)
            return
        grid = self._node_grid()
        head = (self.attractions.data, np.int32(self.attraction_count), self.nodes.data)
        tail = (np.float32(radius), *grid.geometry_args(), *grid.search_args())
        self.program.kernel(f"{kernel}_grid").over(self.attraction_count, LOCAL_SIZE, *head, *tail)

    # }}}

    def count_active_attractions(self) -> int:
        """The active attractions (the view's status line). ``count_on_device``: CountActiveAttractions, read back
        as 4 bytes instead of every record (50 MB at side 160); else the host counts the flags of the records
        (``Runtime.read_back``)."""
        if not self.count_on_device:
            return int((self.runtime.read_back(self.attractions)["active"] != 0).sum())
        cl.enqueue_fill_buffer(self.runtime.queue, self.active_count.data, np.int32(0), 0, self.active_count.nbytes)
        self.program.kernel("CountActiveAttractions").over(
            self.attraction_count,
            LOCAL_SIZE,
            self.attractions.data,
            np.int32(self.attraction_count),
            self.active_count.data,
        )
        return int(self.runtime.read_back(self.active_count)[0])

    def stats(self) -> dict:
        return {**super().stats(), "search": self.params.search}


# }}}

SHORT_RUN_PACE = {"iterations": 5, "growth_speed": 44.0}
"""The scenes' pace: the book's Update runs ``iterations`` Steps a frame (its inspector allows 1-5: 5 here), and
growth_speed is twice the Line scene's 22, so that a node matures in 1-3 Steps instead of 3-11. The scene values
grow the tree in about 100 frames; at this pace 10 steps (50 Steps) show it grown, as the chapter's figures do. The
Params class keeps the book's values (iterations 1, growth_speed 22): ``--set iterations=1 growth_speed=22`` is
the Line scene's own pace, which the page's loop shows."""

BOOK_PACE = {"iterations": 1, "growth_speed": 22.0}
"""The Line and TubularEdge scenes' own pace (SpaceColonization.cs: one Step a frame, growthSpeed 22)."""

SCENES = [
    Scene(
        "space_colonization",
        Simulation,
        "GPU space colonization: a tree grows through a sphere of attraction points (vol.4 ch.1)",
        SHORT_RUN_PACE,
        preview={"steps": 40},
        interactive={"side": 20},
        animation=Animation(
            "the branches grow from the seeds through the attraction cloud, at the book's pace (one Step a frame)",
            every=3,
            start=12,
            overrides=BOOK_PACE,
        ),
        at_scale=AtScale(gpu={"side": 160, "search": "grid"}, cpu={"side": 40, "search": "grid"}),
    ),
    Scene(
        "space_colonization_tubes",
        Simulation,
        "The same tree drawn as capsules by a geometry shader (vol.4 ch.1, TubularEdge scene)",
        {"render": "tubes", **SHORT_RUN_PACE},
        preview={"steps": 40},
        interactive={"side": 20},
    ),
]
