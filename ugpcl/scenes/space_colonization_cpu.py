"""The blog's CPU space colonization: a tree grows its crown, then its roots (B. Olij, "Space Colonization Algorithm
Part 1", blog post, 2014: the CPU counterpart of Unity Graphics Programming vol.4 ch.1;
docs/chapters/12-space-colonization.md).

No kernels: one ``step`` runs ``iterations`` of the blog's doIteration, in numpy float64
(``ugpcl.geometry.space_colonization.BlogTree``): every attraction point compares its closest vertex with the
vertices grown since the last iteration, points within the cut-off distance of their closest vertex die, and every
vertex pulled by points within the max distance grows one normalised branch (plus the bias) towards their mean
direction. Reset grows the trunk and appends the three crown clouds; when the crown stage ends the roots cloud is
appended and the roots stage runs; then nothing grows.

Pace: the blog's demo animates one doIteration a frame, and says that for real use one runs the algorithm and works
with the finished tree. The Params class keeps one a step (the demo); the scene runs 10 (``SHORT_RUN_PACE``), so
that 10 steps (100 iterations) end the crown stage (about 95 iterations) and show the grown tree;
``--set iterations=1`` is the demo's pace.

Differences from the blog: ``repeat_guard`` (on by default; ``--set repeat_guard=false`` is the blog) stops a vertex
growing to the point it grew to last time; a stage also ends when an iteration grows nothing new or after
``max_iterations`` (the blog loops forever on a trapped vertex), and ``stats()`` says which stage stalled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import space_colonization as geo
from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..scene import Params as BaseParams
from ..scene import PreviewCheck, Scene, param
from ..scene import Simulation as BaseSimulation

CROWN_CLOUDS = ((75.0, 50.0), (90.0, 75.0), (100.0, 90.0))
"""(outer, inner) radius of the blog demo's three crown clouds, appended one after the other."""


@dataclass(frozen=True)
class Params(BaseParams):
    crown_points: tuple[int, int, int] = param((800, 300, 50), 0, 1 << 20)
    """Points of the three crown clouds (blog demo: generateAttractionPoints(800, 75, 50 ...), (300, 90, 75 ...),
    (50, 100, 90 ...))."""
    aspect: float = param(2.0, 0.0, 100.0, lo_open=True)
    """Vertical stretch of the crown clouds (blog: pAspect). Up to 100."""
    offset_y: float = param(30.0, -1e4, 1e4)
    """Height of the crown clouds' base (blog: pOffsetY).
    Within 1e4: the view and the .npz keep float32 positions to 1e-3."""
    trunk_height: float = param(30.0, -1e4, 1e4)
    """The trunk: growBranch(0, (0, trunk_height, 0)) before the first iteration.
    Within 1e4: the view and the .npz keep float32 positions to 1e-3."""
    max_distance: float = param(100.0, 0.0, 1e4, lo_open=True)
    """A point pulls its closest vertex within this distance (blog: pMaxDistance, the paper's d_i).
    Up to 1e4: the view and the .npz keep float32 positions to 1e-3."""
    branch_size: float = param(2.0, 0.0, 1e4, lo_open=True)
    """Length of every new branch (blog: pBranchSize, the paper's D).
    Up to 1e4: the view and the .npz keep float32 positions to 1e-3."""
    cut_off_distance: float = param(10.0, 0.0, 1e4, lo_open=True)
    """A point this close to its closest vertex is removed (blog: pCutOffDistance, the paper's d_k).
    Up to 1e4: the view and the .npz keep float32 positions to 1e-3."""
    bias: tuple[float, float, float] = param((0.1, 0.2, 0.0), -1e4, 1e4)
    """Added to every new branch after the normalised step (blog: pBias).
    Within 1e4: the view and the .npz keep float32 positions to 1e-3."""
    root_points: int = param(100, 0, 1 << 20)
    """Points of the roots cloud generated when the crown is done (blog demo: 100, 50, 10, 0.2, -3)."""
    root_outer: float = param(50.0, 0.0, 1e4, lo_open=True)
    """Outer radius of the roots cloud. Up to 1e4: the view and the .npz keep float32 positions to 1e-3."""
    root_inner: float = param(10.0, 0.0, 1e4)
    """Inner radius of the roots cloud. Up to 1e4: the view and the .npz keep float32 positions to 1e-3."""
    root_aspect: float = param(0.2, 0.0, 100.0, lo_open=True)
    """Vertical stretch of the roots cloud. Up to 100."""
    root_offset_y: float = param(-3.0, -1e4, 1e4)
    """Base height of the roots cloud. Within 1e4: the view and the .npz keep float32 positions to 1e-3."""
    root_max_distance: float = param(25.0, 0.0, 1e4, lo_open=True)
    """pMaxDistance of the roots stage. Up to 1e4: the view and the .npz keep float32 positions to 1e-3."""
    root_branch_size: float = param(2.0, 0.0, 1e4, lo_open=True)
    """pBranchSize of the roots stage. Up to 1e4: the view and the .npz keep float32 positions to 1e-3."""
    root_cut_off_distance: float = param(5.0, 0.0, 1e4, lo_open=True)
    """pCutOffDistance of the roots stage. Up to 1e4: the view and the .npz keep float32 positions to 1e-3."""
    root_bias: tuple[float, float, float] = param((0.0, 0.0, 0.0), -1e4, 1e4)
    """pBias of the roots stage. Within 1e4: the view and the .npz keep float32 positions to 1e-3."""
    clear_leftovers: bool = False
    """Drop the crown's stuck points before the roots stage (blog: pClear false keeps them)."""
    repeat_guard: bool = True
    """A vertex does not grow to the point it grew to last time (ugpcl, on by default). false = the blog: a trapped
    vertex regrows the same point every iteration and the stage is ended by ugpcl's stall detector."""
    max_iterations: int = param(2000, 1, 1 << 20)
    """Iterations per stage at most (ugpcl)."""
    iterations: int = param(1, 1, 1000, live=True)
    """doIteration calls per step (ugpcl; the blog's demo animates one a frame)."""

    limits = ("root_inner < root_outer",)

    def check(self) -> None:
        if self.root_inner >= self.root_outer:
            raise self.broken(self.limits[0])


class Simulation(BaseSimulation):
    """The blog's tree: one doIteration per step, the crown stage, then the roots stage, then nothing."""

    Params = Params
    history = ("vertex_count", "point_count")

    def _reset(self) -> None:
        p = self.params
        self.rng = np.random.default_rng(self.seed)
        self.tree = geo.BlogTree()
        self.tree.grow_branch(0, (0.0, p.trunk_height, 0.0))
        for count, (outer, inner) in zip(p.crown_points, CROWN_CLOUDS, strict=True):
            self.tree.add_points(geo.hemisphere_cloud(count, outer, inner, p.aspect, p.offset_y, self.rng))
        self.stage = 0
        self.stage_iterations = np.zeros(2, np.int32)
        self.stalled = np.zeros(2, bool)
        self.root_stage_first_vertex = -1

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
            roots = geo.hemisphere_cloud(
                p.root_points, p.root_outer, p.root_inner, p.root_aspect, p.root_offset_y, self.rng
            )
            self.tree.add_points(roots, clear=p.clear_leftovers)

    def _step(self, dt: float) -> None:
        for _ in range(self.params.iterations):
            self.do_iteration()

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

    def mesh(self) -> Mesh:
        """The tree's vertices (blog units) and no triangles: the blog's tree is line segments (``export_mesh``)."""
        return Mesh(self.tree.vertices, np.zeros((0, 3)))

    def export_mesh(self, path) -> None:
        """--mesh: the segments as lines between ``mesh()``'s vertices (.obj or .glb; .ply holds no lines)."""
        write_mesh(path, self.mesh(), lines=np.asarray(self.tree.segments, np.int64).reshape(-1, 2))


SHORT_RUN_PACE = {"iterations": 10}
"""The scene's pace: 10 doIterations a step, so that a 10-step run shows the grown crown (the demo's pace is 1)."""

SCENES = [
    Scene(
        "space_colonization_cpu",
        Simulation,
        "The blog's CPU space colonization: crown, then roots (vol.4 ch.1 + B. Olij 2014)",
        SHORT_RUN_PACE,
        preview={"steps": 30},
        preview_check=PreviewCheck(min_subject=0.02, sparse="thin branches and their node points"),
    ),
]
