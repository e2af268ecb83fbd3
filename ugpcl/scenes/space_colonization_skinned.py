"""Space colonization inside a dancing figure: nodes grow in bind space and are skinned by their one bone (Unity
Graphics Programming vol.4 ch.1, section 1.4 "Application": the SkinnedAnimation scene and the book's
SkinnedSpaceColonization.cs/.compute; docs/chapters/12-space-colonization.md).

Kernel order (clkernels/space_colonization_skinned.cl): once per figure SetupSkin (each attraction takes the bone of
its nearest mesh vertex); ``reset`` runs SetupAttractions (the cloud is kept, every attraction live again), Setup,
Seed (plus the bone of the nearest attraction), one step and Animate; each ``step`` runs, while the node pool has free
slots, Search, Attract (the candidate carries the bone of the nearest attraction pulling its node), ConnectCount,
Connect and Remove, then always Grow, all in bind space (the host side is ``GrowthSimulation`` of the sphere scene,
with its one read-back per Step and its _tiled loops on GPUs), and then Animate (``animated = (bone matrix . bind
pose) . position`` with the figure's pose at the clip time).

Differences from the book: the figure is procedural (``ugpcl.geometry.skinned_figure``: 12 bones, one capsule each,
a looping dance) instead of the book's character, and its attraction cloud is sampled here (VolumeSampler: voxels,
Poisson darts, those outside the surface dropped) instead of baked into an asset; ``repeat_guard`` is on by default as
in the sphere scene (``--set repeat_guard=false`` is the book); the skinned kernels keep the book's all-pairs loops
(no grid variant; on GPUs read through __local tiles, the same results).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import skinned_figure
from ..scene import ParamError, PreviewCheck, Scene, param
from .space_colonization import LOCAL_SIZE, SHORT_RUN_PACE, GrowthParams, GrowthSimulation

# {{{ records (clkernels/include/space_colonization.h)

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

# }}}


@dataclass(frozen=True)
class Params(GrowthParams):
    resolution: int = param(100, 8, 256)
    """Voxels along the figure's largest extent (VolumeSampler window: resolution; the book's asset: 100)."""
    sample_distance: float = param(1.0, 1.0, 4.0)
    """Smallest distance between attraction points, voxels (VolumeSampler: r)."""
    tries: int = param(8, 1, 64)
    """Darts thrown around a sample before it is retired (VolumeSampler's Poisson sampling)."""
    unit_scale: float = param(2.5, 1.0, 10.0)
    """Distance unit = voxel size x unit_scale (book: unitScale)."""
    anim_time: float = param(0.0, 0.0, 1e6)
    """Animation clock at reset, s of the clip. Up to 1e6 s: float32 time still resolves 1/16 s."""
    anim_speed: float = param(0.35, 0.0, 1e3, live=True, ignored_when={"animate": False})
    """Clip seconds per second (book scene: Animator speed 0.35). Up to 1e3."""
    anim_period: float = param(2.4, 0.1, 1e4, live=True)
    """Length of the dance loop, clip seconds. Up to 1e4 s."""
    animate: bool = param(True, live=True)
    """Play the animation (false: frozen at the current clip time). Growth never depends on it."""


class Simulation(GrowthSimulation):
    """The book's SkinnedSpaceColonization.cs on the procedural figure: growth in bind space, nodes skinned by their
    one bone every step (Animate)."""

    Params = Params
    attraction_dtype = SKINNED_ATTRACTION_DTYPE
    node_dtype = SKINNED_NODE_DTYPE
    candidate_dtype = SKINNED_CANDIDATE_DTYPE
    drawn_position = "animated"  # the skinned scene draws and exports what it shows
    figure_key: tuple | None = None
    """(resolution, sample_distance, tries, seed) of the figure's cloud on the device; a reset keeps it if unchanged."""

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program("space_colonization_skinned")
        key = (p.resolution, p.sample_distance, p.tries, self.seed)
        if self.figure_key != key:  # the book samples the volume and runs SetupSkin once
            self._build_figure(key)
        self.figure = skinned_figure.Figure(period=p.anim_period)
        self.unit = self.voxel_unit * p.unit_scale  # book: unitDistance = volume.unit * unitScale
        self._allocate_nodes(p.node_capacity or self.attraction_count)
        self.setup_attractions()
        rng = np.random.default_rng(self.seed)
        seeds = self.cloud[rng.integers(0, self.attraction_count, p.seed_count)]
        self.anim_time = p.anim_time
        self._start(seeds)
        self.animate()

    def _build_figure(self, key) -> None:
        rt = self.runtime
        cloud, self.voxel_unit = skinned_figure.figure_cloud(*key)
        if not len(cloud):
            raise ParamError(
                f"resolution={key[0]} with sample_distance={key[1]} puts no attraction point inside the figure; "
                "raise resolution or lower sample_distance"
            )
        self.figure_key = key
        self.cloud = cloud
        self.attraction_count = len(cloud)
        records = np.zeros(self.attraction_count, SKINNED_ATTRACTION_DTYPE)
        records["position"], records["bone"], records["nearest"], records["active"] = cloud, -1, -1, 1
        self.attractions = rt.to_device(records)
        vertices, self.mesh_triangles, self.mesh_bone = skinned_figure.Figure().mesh()
        self.mesh_vertices = vertices
        self.setup_skin(vertices, self.mesh_bone)
        self.bind_poses = skinned_figure.Figure().bind_poses()
        self.bind_pose_buffer = rt.to_device(self.bind_poses.astype(np.float32).reshape(-1))
        self.bone_matrix_buffer = rt.zeros(self.bind_poses.size, np.float32)

    def _seed_lookup_args(self) -> tuple:
        """The skinned Seed gives each seed the bone of its nearest attraction."""
        return (self.attractions.data, np.int32(self.attraction_count))

    # {{{ kernels of the application (Setup .. Grow: GrowthSimulation)

    def setup_skin(self, vertices: np.ndarray, bones: np.ndarray) -> None:
        """SetupSkin: each attraction takes the bone of its nearest mesh vertex."""
        rt = self.runtime
        vertex_buffer = rt.to_device(np.ascontiguousarray(vertices, np.float32).reshape(-1))
        bone_buffer = rt.to_device(np.ascontiguousarray(bones, np.int32))
        self.program.kernel("SetupSkin").over(
            self.attraction_count,
            LOCAL_SIZE,
            self.attractions.data,
            np.int32(self.attraction_count),
            vertex_buffer.data,
            bone_buffer.data,
            np.int32(len(vertices)),
        )
        rt.finish()  # the temporary buffers go out of scope (the book's `using` block)

    def setup_attractions(self) -> None:
        """SetupAttractions: every attraction live again, nothing found (the cloud and its bones are kept)."""
        self.program.kernel("SetupAttractions").over(
            self.attraction_count, LOCAL_SIZE, self.attractions.data, np.int32(self.attraction_count)
        )

    def animate(self, bone_matrices: np.ndarray | None = None) -> None:
        """Animate: animated = (bone matrix @ bind pose) @ (position, 1) per live node, with the figure's pose at
        the current clip time unless `bone_matrices` (B, 4, 4) are given (the book reads them from the Animator)."""
        if bone_matrices is None:
            bone_matrices = self.bone_matrices()
        self.bone_matrix_buffer.set(np.ascontiguousarray(bone_matrices, np.float32).reshape(-1))
        self.program.kernel("Animate").over(
            self.capacity,
            LOCAL_SIZE,
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

    def _step(self, dt: float) -> None:
        super()._step(dt)  # growth, in bind space
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


SCENES = [
    Scene(
        "space_colonization_skinned",
        Simulation,
        "Space colonization inside a dancing figure: nodes skinned by their bone (vol.4 ch.1 section 1.4)",
        # the SkinnedAnimation scene's distances; the tube radius is the book's _Thickness 0.01 on its 3.4-unit
        # character, scaled to this 1.8-unit figure
        # at the book's pace (one Step a frame) 10 steps show a few twigs: SHORT_RUN_PACE grows the figure in them
        defaults={
            "influence_distance": 1.91,
            "growth_distance": 0.573,
            "kill_distance": 0.398,
            "tube_radius": 0.0053,
            **SHORT_RUN_PACE,
        },
        preview={"steps": 300},
        interactive={"resolution": 80},
        preview_check=PreviewCheck(fills_frame="the floor runs to the horizon"),
    ),
]
