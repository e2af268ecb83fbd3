"""Procedural modeling: meshes built by rules from parameters (vol.1 ch.1; docs/chapters/01-procedural-modeling.md).

Every sample of the chapter is a scene: the quad, the plane, the mountain and terrain planes, the cylinder beside
the "bad" one that shares its cap vertices, a tube swept along a Catmull-Rom curve with parallel-transported
frames, the procedural tree (``procedural_modeling``) with its growth clip ``_T``, a forest of such trees, and the
L-system. The generators are numpy ports of the book's C# (``ugpcl/geometry/procedural.py``); with
``builder=opencl`` the large ones run as kernels (``clkernels/procedural_modeling.cl``): the plane's vertices,
normals and triangles (terrains up to 4096^2) and the rings of every branch of a forest in one launch.

As in the book, every parameter change rebuilds the mesh (ProceduralModelingEditor calls Rebuild()); ``step`` only
advances time, which the tree uses for its growth ``_T`` (0 to 1 over ``grow_seconds``). The tree starts grown
(``grow_t`` 1, the chapter's figure, so a short run shows the whole tree); ``grow_t=0`` or the viewer's ``g`` key
replays the growth from the ground.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl.cltypes as cltypes

from ..geometry import procedural as pm
from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..resources import Allocation
from ..scene import Animation, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

MATERIALS = ("standard", "uv", "normal", "all")
"""ProceduralModelingMaterial (Standard, UV, Normal) and ugpcl's 'all': the three side by side, as figure 1.2."""
BUILDERS = ("numpy", "opencl")
MAX_GRID = 4096
"""Largest plane side in vertices (the book's inspector stops at 30; the kernels make 4096^2 = 16.8M vertices)."""
CURVES = {
    "scene": ((2.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (-1.0, 1.0, 0.0)),
    "script": ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (-1.0, 0.0, 0.0)),
    "knot": pm.trefoil_knot(12, 0.4),  # ugpcl: a closed, non-planar curve whose frames must twist
}
"""Control points of the tube's curve: Tubular.unity's, CurveBase.cs's default, and a knot."""


@dataclass(frozen=True)
class MeshParams(BaseParams):
    material: str = param("standard", choices=MATERIALS, live=True)
    """Shading of the view: Standard (lit), UV (u, v, 0) or Normal ((n + 1) / 2), or all three side by side
    (book: ProceduralModelingMaterial)."""


class MeshSimulation(BaseSimulation):
    """What every scene of the chapter shares: ``reset`` builds the mesh from the parameters, ``step`` only
    advances time, ``state`` is the mesh's arrays."""

    def _reset(self) -> None:
        self.built = self.build()

    def build(self) -> Mesh:
        raise NotImplementedError

    def _step(self, dt: float) -> None:
        """Nothing to run: the mesh was built at reset and does not change with time."""

    def mesh(self) -> Mesh:
        return self.built

    def export_mesh(self, path) -> None:
        write_mesh(path, self.mesh())

    def state(self) -> dict[str, np.ndarray]:
        m = self.mesh()
        return {"vertices": m.vertices, "normals": m.normals, "uv": m.uvs, "triangles": m.faces.astype(np.uint32)}

    def stats(self) -> dict:
        m = self.mesh()
        return {**super().stats(), "vertices": len(m.vertices), "triangles": len(m.faces)}


# {{{ Quad.cs


@dataclass(frozen=True)
class QuadParams(MeshParams):
    size: float = param(1.0, 0.1, 10.0)
    """Side length (book: Quad.size)."""


class QuadSimulation(MeshSimulation):
    """Quad.cs: four vertices, two triangles."""

    Params = QuadParams

    def build(self) -> Mesh:
        return pm.quad(self.params.size)


# }}}

# {{{ Plane.cs, MountainPlane.cs, TerrainPlane.cs


@dataclass(frozen=True)
class PlaneParams(MeshParams):
    width_segments: int = param(8, 2, MAX_GRID)
    """Vertices per row (book: widthSegments, inspector 2-30)."""
    height_segments: int = param(8, 2, MAX_GRID)
    """Vertices per column (book: heightSegments, inspector 2-30)."""
    width: float = param(1.0, 0.1, 1000.0)
    """Extent along x (book: width)."""
    height: float = param(1.0, 0.1, 1000.0)
    """Extent along z (book: height)."""
    surface: str = param("flat", choices=("flat", "mountain", "terrain"))
    """Depth(u, v) of ParametricPlaneBase: none (Plane.cs), MountainPlane.cs or TerrainPlane.cs."""
    depth: float = param(1.0, 0.0, 1000.0, ignored_when={"surface": "flat"})
    """Height scale of the mountain and terrain (book: depth)."""
    power: float = param(1.25, 0.5, 3.0, used_only_when={"surface": "mountain"})
    """Mountain falloff exponent (book: MountainPlane.power)."""
    u_scale: float = param(1.2, 0.1, 10.0, used_only_when={"surface": "terrain"})
    """Terrain noise frequency along u (book: TerrainPlane.uScale)."""
    v_scale: float = param(1.5, 0.1, 10.0, used_only_when={"surface": "terrain"})
    """Terrain noise frequency along v (book: vScale)."""
    u_offset: float = param(0.0, -1e4, 1e4, used_only_when={"surface": "terrain"})
    """Terrain noise offset along u (book: uOffset)."""
    v_offset: float = param(0.0, -1e4, 1e4, used_only_when={"surface": "terrain"})
    """Terrain noise offset along v (book: vOffset)."""
    builder: str = param("numpy", choices=BUILDERS)
    """Who builds the mesh: numpy (the book's loops as arrays) or the GridVertices/GridNormals/GridTriangles kernels."""


DEPTH_FN = {"flat": 0, "mountain": 1, "terrain": 2}
"""-D DEPTH_FN of clkernels/procedural_modeling.cl per surface."""


class PlaneSimulation(MeshSimulation):
    """Plane.cs, and ParametricPlaneBase.cs with MountainPlane's or TerrainPlane's Depth; the noise's
    permutation is drawn from the run's seed."""

    Params = PlaneParams

    def _reset(self) -> None:
        self.perm = pm.perlin_permutation(self.seed)
        self.grid = None
        if self.params.builder == "opencl":
            self.make_grid_buffers()
        super()._reset()

    def make_grid_buffers(self) -> None:
        """``grid``: the device arrays of GridVertices, GridNormals and GridTriangles for this plane (builder=opencl;
        the bench makes them for a numpy plane too)."""
        p, rt = self.params, self.runtime
        W, H = p.width_segments, p.height_segments
        self.grid = {
            "perm": rt.to_device(self.perm),
            "positions": rt.empty(3 * W * H, np.float32),
            "normals": rt.empty(3 * W * H, np.float32),
            "uvs": rt.empty(2 * W * H, np.float32),
            "triangles": rt.empty(6 * (W - 1) * (H - 1), np.int32),
        }

    def build(self) -> Mesh:
        p = self.params
        if p.builder == "opencl":
            return self.build_opencl()
        depth = {
            "flat": None,
            "mountain": pm.mountain_depth(p.power, p.depth),
            "terrain": pm.terrain_depth(p.u_scale, p.v_scale, p.u_offset, p.v_offset, p.depth, self.perm),
        }[p.surface]
        return pm.plane(p.width_segments, p.height_segments, p.width, p.height, depth)

    def launch_grid(self) -> dict:
        """GridVertices, GridNormals, GridTriangles: the plane's device arrays (not read back)."""
        p, rt = self.params, self.runtime
        W, H = p.width_segments, p.height_segments
        program = rt.program("procedural_modeling", DEPTH_FN=DEPTH_FN[p.surface])
        g = self.grid
        shape = cltypes.make_float4(p.power, p.u_scale, p.v_scale, p.u_offset)
        shape2 = cltypes.make_float4(p.v_offset, p.depth, p.width, p.height)
        size = (np.int32(W), np.int32(H))
        program.kernel("GridVertices")((W, H), None, g["positions"], g["uvs"], g["perm"], *size, shape, shape2)
        program.kernel("GridNormals")((W, H), None, g["positions"], g["normals"], *size)
        program.kernel("GridTriangles")((W - 1, H - 1), None, g["triangles"], *size)
        return g

    def build_opencl(self) -> Mesh:
        g = self.launch_grid()
        normals = g["normals"].get() if self.params.surface != "flat" else None
        mesh = Mesh(g["positions"].get(), g["triangles"].get(), normals, g["uvs"].get())
        if normals is None:  # Plane.cs sets +y; only ParametricPlaneBase recalculates
            mesh.normals = np.tile(np.float32([0, 1, 0]), (len(mesh.vertices), 1))
        return mesh


# }}}

# {{{ Cylinder.cs, BadCylinder.cs


@dataclass(frozen=True)
class CylinderParams(MeshParams):
    height: float = param(3.0, 0.1, 10.0)
    """Length along y (book: height)."""
    radius: float = param(1.0, 0.1, 10.0)
    """Radius (book: radius)."""
    segments: int = param(16, 3, 256)
    """Sides around the circle (book: segments, inspector 3-32)."""
    open_ended: bool = param(True)
    """True builds the caps (sic: the book's name says the opposite; book: openEnded)."""
    bad: bool = param(False)
    """BadCylinder.cs: the caps share the side's vertices, and so its normals (figure 1.9)."""


class CylinderSimulation(MeshSimulation):
    """Cylinder.cs or BadCylinder.cs."""

    Params = CylinderParams

    def build(self) -> Mesh:
        return self.mesh_of(self.params.bad)

    def mesh_of(self, bad: bool) -> Mesh:
        """This cylinder as Cylinder.cs (bad=False) or BadCylinder.cs builds it (the view shows both)."""
        p = self.params
        return pm.cylinder(p.height, p.radius, p.segments, p.open_ended, bad)


# }}}

# {{{ Tubular.cs


@dataclass(frozen=True)
class TubularParams(MeshParams):
    tubular_segments: int = param(20, 2, 1000)
    """Rings along the curve (book: tubularSegments, inspector 2-50)."""
    radial_segments: int = param(8, 2, 256)
    """Vertices around a ring (book: radialSegments, inspector 2-50)."""
    radius: float = param(0.5, 0.01, 5.0)
    """Tube radius (book: radius)."""
    closed: bool = param(False)
    """Close the tube: the curve and the frames wrap, the last ring repeats the first (book: closed)."""
    curve: str = param("script", choices=tuple(CURVES))
    """Control points: Tubular.unity's, CurveBase.cs's default, or a trefoil knot (ugpcl)."""
    variant: str = param("fixed", choices=("fixed", "book"), used_only_when={"closed": True})
    """Closed frames: the twist correction as meant (fixed), or the book's, converted with Deg2Rad twice."""


class TubularSimulation(MeshSimulation):
    """Tubular.cs: a circle swept along a Catmull-Rom curve, oriented by parallel-transported frames."""

    Params = TubularParams

    def build(self) -> Mesh:
        p = self.params
        self.curve = pm.CatmullRomCurve(CURVES[p.curve], closed=p.closed)
        self.tube = pm.tubular(self.curve, p.tubular_segments, p.radial_segments, p.radius, p.closed, p.variant)
        return self.tube.mesh

    def state(self) -> dict[str, np.ndarray]:
        f = self.tube.frames
        return {
            **super().state(),
            "tangents": self.tube.tangents,
            "curve_points": self.tube.centers,
            "control_points": np.asarray(CURVES[self.params.curve], np.float32),
            "frame_t": f.tangent.astype(np.float32),
            "frame_n": f.normal.astype(np.float32),
            "frame_b": f.binormal.astype(np.float32),
        }


# }}}

# {{{ ProceduralTree.cs


@dataclass(frozen=True)
class TreeParams(MeshParams):
    generations: int = param(5, 2, 7)
    """Branching depth (book: generations)."""
    length: float = param(1.0, 0.5, 5.0)
    """Length of the trunk (book: length)."""
    radius: float = param(0.15, 0.1, 2.0)
    """Radius of the trunk (book: radius)."""
    random_seed: int = param(0, 0, 2**31 - 1)
    """The tree's pattern (book: TreeData.randomSeed); the run's --seed is the generator's key beside it."""
    length_attenuation: float = param(0.9, 0.5, 0.99)
    """A child's length over its parent's, for the last child (book: lengthAttenuation)."""
    radius_attenuation: float = param(0.6, 0.5, 0.99)
    """A branch's tip radius over its base radius (book: radiusAttenuation)."""
    branches_min: int = param(1, 1, 3)
    """Fewest children of a branch (book: branchesMin)."""
    branches_max: int = param(3, 1, 3)
    """Most children of a branch (book: branchesMax)."""
    growth_angle_min: float = param(-15.0, -45.0, 0.0)
    """Smallest random turn of a child, degrees (book: growthAngleMin)."""
    growth_angle_max: float = param(15.0, 0.0, 45.0)
    """Largest random turn of a child, degrees (book: growthAngleMax)."""
    growth_angle_scale: float = param(4.0, 1.0, 10.0)
    """Factor on the turns at the tips, 1 at the trunk (book: growthAngleScale)."""
    height_segments: int = param(10, 4, 20)
    """Rings along a branch minus one (book: heightSegments)."""
    radial_segments: int = param(8, 4, 20)
    """Vertices around a ring minus one (book: radialSegments)."""
    bend_degree: float = param(0.1, 0.0, 0.35)
    """Random sideways bend of a branch's middle, times its length (book: bendDegree)."""
    grow_t: float = param(1.0, 0.0, 1.0)
    """The shader's _T at the start: fragments with uv.y > _T are clipped (1: fully grown, the chapter's figure;
    0: the tree grows from the ground over grow_seconds)."""
    grow_seconds: float = param(3.0, 0.1, 600.0, live=True)
    """Seconds for _T to go from 0 to 1."""
    trees: int = param(1, 1, 4096)
    """Trees in a square grid (ugpcl: the forest); tree k is the same alone or in a forest."""
    spacing: float = param(3.0, 0.5, 100.0, ignored_when={"trees": 1})
    """Distance between neighbouring trees of the forest."""
    builder: str = param("numpy", choices=BUILDERS)
    """Who builds the rings and triangles: numpy or the TubeRings/TubeTriangles kernels (one launch for all)."""

    def check(self) -> None:
        if self.branches_min > self.branches_max:
            raise ValueError(f"branches_min ({self.branches_min}) must be <= branches_max ({self.branches_max})")


class TreeSimulation(MeshSimulation):
    """ProceduralTree.cs: branches that spawn branches, each a short tube, merged into one mesh."""

    Params = TreeParams
    history = ("grow_t",)

    def _reset(self) -> None:
        self.grow_t = self.params.grow_t
        super()._reset()

    @classmethod
    def allocations(cls, params: TreeParams) -> list[Allocation]:
        """The forest's mesh: branches a tree is expected to grow (children drawn evenly from branches_min to
        branches_max, a margin of 1.5), each a tube of (height_segments + 1) x (radial_segments + 1) vertices.
        Host: about 210 bytes a vertex at the numpy builder's peak (measured); device (opencl builder): the ring
        kernels' positions, normals, tangents, uvs (48 bytes a vertex) and triangles."""
        p = params
        children = (p.branches_min + p.branches_max) / 2
        branches = int(1.5 * p.trees * sum(children**g for g in range(p.generations + 1)))
        vertices = branches * (p.height_segments + 1) * (p.radial_segments + 1)
        found = [Allocation("tree meshes (host)", 210 * vertices, "trees", host=True)]
        if p.builder == "opencl":
            triangles = 24 * branches * p.height_segments * p.radial_segments
            found.append(Allocation("tree mesh vertex buffer", 16 * vertices, "trees", count=3))  # 12 + 12 + 16 + 8
            found.append(Allocation("tree mesh triangles", triangles, "trees"))
        return found

    def build(self) -> Mesh:
        p = self.params
        origins = pm.forest_origins(p.trees, p.spacing)
        self.branches = pm.grow_trees(p, p.trees, self.seed, origins)
        self.ring_buffers = None
        if p.builder == "opencl":
            self.make_ring_buffers()
            mesh, self.tangents = self.build_opencl()
        else:
            mesh, self.tangents = pm.tree_mesh(self.branches, p.radial_segments)
        return mesh

    def make_ring_buffers(self) -> None:
        """``ring_buffers``: TubeRings' inputs (the rings of every branch, ``pm.tree_rings``, uploaded) and count,
        and the mesh's device arrays, for the branches just grown (builder=opencl; the bench makes them for a numpy
        forest too)."""
        p, rt = self.params, self.runtime
        rings = pm.tree_rings(self.branches)
        n = len(rings.v) * (p.radial_segments + 1)
        self.ring_buffers = {
            "inputs": [rt.to_device(np.asarray(a, np.float32)) for a in vars(rings).values()],
            "count": len(rings.v),
            "positions": rt.empty(3 * n, np.float32),
            "normals": rt.empty(3 * n, np.float32),
            "tangents": rt.empty(4 * n, np.float32),
            "uvs": rt.empty(2 * n, np.float32),
            "triangles": rt.empty(6 * len(self.branches) * p.height_segments * p.radial_segments, np.int32),
        }

    def launch_rings(self) -> dict:
        """TubeRings and TubeTriangles over every branch of every tree: the device arrays (not read back)."""
        p, rt = self.params, self.runtime
        out = self.ring_buffers
        inputs, m = out["inputs"], out["count"]
        program = rt.program("procedural_modeling")
        n = m * (p.radial_segments + 1)
        program.kernel("TubeRings").over(
            n,
            64,
            *inputs,
            np.int32(m),
            np.int32(p.radial_segments),
            out["positions"],
            out["normals"],
            out["tangents"],
            out["uvs"],
        )
        quads = len(self.branches) * p.height_segments * p.radial_segments
        program.kernel("TubeTriangles").over(
            quads,
            64,
            out["triangles"],
            np.int32(len(self.branches)),
            np.int32(p.height_segments),
            np.int32(p.radial_segments),
        )
        return out

    def build_opencl(self) -> tuple[Mesh, np.ndarray]:
        out = self.launch_rings()
        mesh = Mesh(out["positions"].get(), out["triangles"].get(), out["normals"].get(), out["uvs"].get())
        return mesh, out["tangents"].get().reshape(-1, 4)

    def _step(self, dt: float) -> None:
        self.grow_t = min(1.0, self.grow_t + dt / self.params.grow_seconds)  # _T of ProceduralTree.cginc

    def restart_growth(self) -> None:
        """_T back to 0: the tree grows again."""
        self.grow_t = 0.0

    def visible(self) -> np.ndarray:
        """Which vertices the growth clip keeps at the current _T (the shader discards fragments with uv.y > _T)."""
        return self.mesh().uvs[:, 1] <= self.grow_t

    def state(self) -> dict[str, np.ndarray]:
        b = self.branches
        return {
            **super().state(),
            "tangents": self.tangents,
            "grow_t": np.float32(self.grow_t),
            "branch_tree": b.tree.astype(np.int32),
            "branch_from": b.start.astype(np.float32),
            "branch_to": b.end.astype(np.float32),
            "branch_generation": b.generation.astype(np.int32),
            "branch_parent": b.parent.astype(np.int32),
            "branch_length": b.length.astype(np.float32),
            "branch_offset": b.offset.astype(np.float32),
        }

    def stats(self) -> dict:
        return {**super().stats(), "branches": len(self.branches), "trees": self.params.trees, "_T": self.grow_t}


# }}}

# {{{ LSystem.cs


@dataclass(frozen=True)
class LSystemParams(MeshParams):
    depth: int = param(5, 1, 20)
    """Recursion depth: 2^depth - 1 lines (book: depth, inspector 1-8)."""
    length: float = param(2.0, 1.0, 5.0)
    """Length of the trunk (book: length)."""
    attenuation: float = param(0.635, 0.5, 0.9)
    """Length factor per level (book: attenuation)."""
    angle: float = param(20.0, 0.0, 90.0)
    """Turn of each branch from its parent, degrees (book: angle)."""
    color: tuple[float, float, float] = param((0.0, 0.0, 0.0), 0.0, 1.0, live=True)
    """Line colour (book: color)."""


class LSystemSimulation(MeshSimulation):
    """LSystem.cs: a line, then two half-turned copies at its end, recursively (figure 1.15)."""

    Params = LSystemParams

    def build(self) -> Mesh:
        p = self.params
        self.segments, self.level = pm.lsystem_segments(p.depth, p.length, p.attenuation, p.angle)
        return Mesh(self.segments.reshape(-1, 3), np.zeros((0, 3), np.int32))

    def export_mesh(self, path) -> None:
        write_mesh(path, self.mesh(), lines=np.arange(2 * len(self.segments)).reshape(-1, 2))

    def state(self) -> dict[str, np.ndarray]:
        return {"segments": self.segments, "level": self.level}

    def stats(self) -> dict:
        return {"steps": self.steps, "time": self.time, "segments": len(self.segments)}


# }}}


SCENES = [
    Scene(
        "procedural_modeling",
        TreeSimulation,
        "A procedural tree of random branches, each a tube, growing by its _T clip (vol.1 ch.1)",
        view="TreeView",
        animation=Animation(
            "the tree grows as the book's `_T` clip goes from 0 to 1 (in 2.2 s here, then it stays grown) while the "
            "camera swings",
            every=4,
            start=24,
            swing=25.0,
            overrides={"grow_t": 0.0, "grow_seconds": 2.2},
        ),
        preview_check=PreviewCheck(min_subject=0.02, sparse="one tree of thin branches"),
    ),
    Scene(
        "procedural_modeling_forest",
        TreeSimulation,
        "A forest of procedural trees whose tube rings one kernel builds (vol.1 ch.1, ugpcl)",
        {"trees": 64, "builder": "opencl"},
        view="TreeView",
    ),
    Scene(
        "procedural_modeling_quad",
        QuadSimulation,
        "The quad: four vertices, two triangles; lit, uv and normal shading (vol.1 ch.1)",
        {"size": 2.0, "material": "all"},
        view="QuadView",
    ),
    Scene(
        "procedural_modeling_plane",
        PlaneSimulation,
        "A plane of W x H vertices (vol.1 ch.1)",
        {"material": "all"},
        view="PlaneView",
        preview={"steps": 1, "width": 2.0, "height": 2.0},  # 2 x 2 planes: the three copies fill the row
    ),
    Scene(
        "procedural_modeling_mountain",
        PlaneSimulation,
        "A plane raised by a power falloff: MountainPlane (vol.1 ch.1)",
        {"surface": "mountain", "power": 1.33, "depth": 7.16, "width": 2.0, "height": 2.0, "material": "normal"},
        view="PlaneView",
    ),
    Scene(
        "procedural_modeling_terrain",
        PlaneSimulation,
        "A plane raised by Perlin noise: TerrainPlane; up to 4096^2 vertices by kernels (vol.1 ch.1)",
        {
            "surface": "terrain",
            "u_scale": 2.67,
            "v_scale": 2.6,
            "u_offset": 0.77,
            "v_offset": 1.0,
            "width_segments": 12,
            "height_segments": 12,
            "width": 2.0,
            "height": 2.0,
            "material": "normal",
        },
        view="PlaneView",
    ),
    Scene(
        "procedural_modeling_cylinder",
        CylinderSimulation,
        "The cylinder with caps of their own, beside the bad one sharing its side's normals (vol.1 ch.1)",
        {"material": "all"},
        view="CylinderView",
    ),
    Scene(
        "procedural_modeling_bad_cylinder",
        CylinderSimulation,
        "BadCylinder: caps fanned onto the side's vertices, lit wrongly (vol.1 ch.1, figure 1.9)",
        {"bad": True, "material": "all"},
        view="CylinderView",
    ),
    Scene(
        "procedural_modeling_tubular",
        TubularSimulation,
        "A tube along a Catmull-Rom curve, with its parallel-transported frames (vol.1 ch.1)",
        {"tubular_segments": 25, "radial_segments": 10, "radius": 0.25, "curve": "scene", "material": "all"},
        view="TubularView",
    ),
    Scene(
        "procedural_modeling_lsystem",
        LSystemSimulation,
        "The L-system: a line branching left and right, recursively (vol.1 ch.1, figure 1.15)",
        {"depth": 7, "length": 1.0, "angle": 30.0},
        view="LSystemView",
        preview={"steps": 1},
        preview_check=PreviewCheck(min_subject=0.003, sparse="one-pixel lines on white"),
    ),
]
