"""Tessellation + displacement driven by a 2D fluid: Unity's Plane, subdivided on the GPU by edge length and raised
by the fluid's density (vol.4 ch.6 "Tessellation & Displacement"; docs/chapters/17-tessellation.md).

The fluid is a ``stable_fluids_2d`` Simulation this scene owns and drives (vol.4's Solver2D.compute is a stripped
copy of vol.1's): per frame the scripted stroke (or the mouse) holds the brush, the fluid steps, and its density
becomes the displacement texture of the plane. The tessellation itself is GLSL in ``viewer/shaders/tessellation.*``
(TCS: edge-length factors with frustum culling, as Unity's UnityEdgeLengthBasedTessCull; TES: barycentric
interpolation and displacement along the normal). Headless, ``ugpcl.geometry.tessellation`` evaluates the same
formulas with numpy: ``tess_factors`` (the TCS for the scene camera) and ``displace_plane_grid`` (a uniform grid
displaced as the TES displaces its vertices); it also holds the sample's plane, camera and light.

variant=book reproduces the sample: vol.4's stripped solver (no pressure sweeps, no AdvectVelocity; the original's
divergence and back-trace), Point-filtered displacement, lighting with the plane's undisplaced normal (Unity's
surface shader never updates normals after `disp`). variant=fixed (default): vol.1's full solver with Stam's
equations, bilinear displacement, normals of the displaced surface. Both cast the light's shadows through the same
tessellation (the sample's addshadow). Differences from the book in both: Jacobi ping-pong instead of racy in-place
Gauss-Seidel; the plane's normal map (normal.tga, not in the repository) is flat, Unity's "bump" default.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..geometry.mesh import Mesh, vertex_normals
from ..geometry.mesh_io import write_mesh
from ..geometry.tessellation import displace_plane_grid, plane_corners, scene_camera, tess_factors
from ..scene import Animation, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation
from .stable_fluids_2d import STROKES
from .stable_fluids_2d import Params as FluidParams
from .stable_fluids_2d import Simulation as FluidSimulation


@dataclass(frozen=True)
class Params(BaseParams):
    grid: int = param(256, 8, 4096)
    """Fluid cells per side, a square grid under the square plane (the original: the window >> lod)."""
    diff: float = param(10.0, 0.0, 1e6, live=True)
    """Density diffusion (book: diff; FuidTessellation's Solver).
    Up to 1e6: a <= 1.7e13 keeps the Jacobi sums finite in float32."""
    visc: float = param(100.0, 0.0, 1e6, live=True, ignored_when={"density_only": True})
    """Velocity diffusion (book: visc). Up to 1e6: a <= 1.7e13 keeps the Jacobi sums finite in float32."""
    velocity_coef: float = param(4.0, 0.0, 1e4, live=True, ignored_when={"density_only": True})
    """Brush velocity gain (book: velocityCoef). Up to 1e4: the sources stay finite in float32."""
    density_coef: float = param(6.0, 0.0, 1e4, live=True)
    """Brush density gain (book: densityCoef). Up to 1e4: the sources stay finite in float32."""
    density_only: bool = param(False, live=True)
    """Skip the velocity step, advect by the brush (book: isDensityOnly)."""
    gs_iterations: int = param(2, 1, 100000, live=True)
    """Jacobi sweeps per diffusion (and per pressure solve in variant=fixed) (book: GS_ITERATE)."""
    source_radius: float = param(0.072, 0.0, 1.0, lo_open=True, live=True)
    """Brush radius in uv units (book: sourceRadius and AddSource.mat _Radius in the scene)."""
    stroke: str = param("circle", choices=STROKES, live=True)
    """Scripted brush path (not in the book: a headless stand-in for the mouse): circle, line, figure8 or none; the
    mouse overrides it."""
    stroke_frames: int = param(0, 0, 1 << 30, live=True, ignored_when={"stroke": "none"})
    """Frames the scripted stroke holds the brush down; 0 = every frame (the button held down throughout).
    At most 2^30 frames."""
    edge_length: float = param(2.0, 2.0, 50.0, live=True)
    """Target length of a tessellated edge on screen, pixels (book: _EdgeLength; TessellationSurface.mat 2)."""
    displacement: float = param(0.5, 0.0, 30.0, live=True)
    """World units per unit of density along the normal (book: _Displacement; the material's 0.5)."""
    negative: bool = param(False, live=True)
    """Displace against the normal (Tessellation.shader's disp subtracts; the surface shader adds)."""
    specular: float = param(0.366, 0.0, 1.0, live=True)
    """Render only: Blinn-Phong exponent / 128 (book: _Specular)."""
    gloss: float = param(0.276, 0.0, 1.0, live=True)
    """Render only: specular scale (book: _Gloss)."""
    color: tuple[float, float, float] = param((0.0, 0.0, 0.0), 0.0, 1.0, live=True)
    """Render only: albedo (book: _Color; the scene's black, so only the specular shows)."""
    spec_color: tuple[float, float, float] = param((1.0, 1.0, 1.0), 0.0, 1.0, live=True)
    """Render only: specular colour (book: _SpecColor)."""
    shadows: bool = param(True, live=True)
    """Render only: the light's shadows (the sample: addshadow fullforwardshadows; its light casts shadows)."""
    lighting: str = param("auto", choices=("auto", "height", "mesh"), live=True)
    """Render only: normals of the displaced height field (height), the plane's own as Unity's surface shader
    (mesh), or auto = mesh for variant=book, height for fixed."""
    variant: str = param("fixed", choices=("fixed", "book"), live=True)
    """fixed: vol.1's full solver (Stam), bilinear displacement; book: vol.4's stripped solver, Point sampling."""
    screen_size: tuple[int, int] = param((1920, 1080), 16, 16384, live=True)
    """Screen the headless tess_factors are evaluated for, pixels (book: _ScreenParams)."""
    mesh_level: int = param(8, 1, 64, live=True)
    """Headless mesh_vertices: (10*level + 1)^2 vertices over the plane."""
    local_size: tuple[int, int] = param((32, 32), 1, 1024, live=True)
    """Work-group shape of the fluid kernels (book: THREAD_X, THREAD_Y = 32)."""

    @property
    def linear_filter(self) -> bool:
        """The displacement texture's filter: LINEAR (fixed) or the original's Point (book)."""
        return self.variant == "fixed"

    @property
    def height_normals(self) -> bool:
        return self.lighting == "height" or (self.lighting == "auto" and self.variant == "fixed")


FLUID_FIELDS = (
    "diff",
    "visc",
    "velocity_coef",
    "density_coef",
    "density_only",
    "gs_iterations",
    "source_radius",
    "stroke",
    "stroke_frames",
    "variant",
    "local_size",
)
"""Params handed to the fluid unchanged."""


class Simulation(BaseSimulation):
    """The fluid (a stable_fluids_2d Simulation) plus the brush's path; the plane lives in the view."""

    Params = Params
    history = ("density", "velocity")

    @classmethod
    def allocations(cls, params: Params) -> list:
        """The fluid's fields on a grid x grid square, sized by ``grid``."""
        fluid = FluidParams(width=params.grid, height=params.grid)
        return [dataclasses.replace(a, param="grid") for a in FluidSimulation.allocations(fluid)]

    def _reset(self) -> None:
        self.fluid = FluidSimulation(self.runtime, self.fluid_params(), self.seed)
        self.fluid.warns_ignored = False  # driven by these Params: update() says what they leave unused
        self.stroke_uv: list[tuple[float, float]] = []
        self.stroke_vel: list[tuple[float, float]] = []

    def fluid_params(self) -> FluidParams:
        """The 2D fluid's Params: vol.4's solver for variant=book, vol.1's for fixed, on a grid x grid square."""
        p = self.params
        shared = {name: getattr(p, name) for name in FLUID_FIELDS}
        return FluidParams(width=p.grid, height=p.grid, solver="vol4" if p.variant == "book" else "vol1", **shared)

    def update(self, **changes) -> None:
        super().update(**changes)  # a new grid resets (a new fluid); everything else is live
        target = self.fluid_params()
        self.fluid.update(**{k: v for k, v in target.to_dict().items() if getattr(self.fluid.params, k) != v})

    def brush(self, u: float, v: float, du: float = 0.0, dv: float = 0.0) -> None:
        """Hold the fluid's brush at uv (u, v) of the plane's texture for the next step (see the fluid's brush)."""
        self.fluid.brush(u, v, du, dv)

    def restart_stroke(self) -> None:
        self.fluid.restart_stroke()

    def _step(self, dt: float) -> None:
        self.fluid.step(dt)
        brush = self.fluid.last_brush
        self.stroke_uv.append(brush[:2] if brush else (math.nan, math.nan))
        self.stroke_vel.append(brush[2:] if brush else (math.nan, math.nan))

    # {{{ state

    def density(self) -> np.ndarray:
        """(grid, grid) float32: the displacement texture (row 0 = v near 0)."""
        return self.fluid.density.read.get()

    def mesh(self) -> Mesh:
        """The displaced plane (the mesh_level grid of ``displace_plane_grid``) in world space, with area-weighted
        normals of the displaced surface. Open, so not watertight."""
        p = self.params
        vertices, triangles, _ = displace_plane_grid(
            self.density(), p.mesh_level, p.displacement, p.negative, p.linear_filter
        )
        return Mesh(vertices, triangles, vertex_normals(vertices, triangles))

    def tess_factors(self) -> np.ndarray:
        """(200, 4) float32: the TCS's outer[0..2], inner for the scene camera on a screen of screen_size."""
        p = self.params
        view, proj, eye = scene_camera(p.screen_size[0] / p.screen_size[1])
        factors = tess_factors(plane_corners(), eye, proj @ view, p.screen_size[1], p.edge_length, p.displacement)
        return factors.astype(np.float32)

    def state(self) -> dict[str, np.ndarray]:
        fluid = self.fluid.state()
        mesh = self.mesh()
        return {
            "density": fluid["density"],
            "velocity": fluid["velocity"],
            "stroke_uv": np.asarray(self.stroke_uv, np.float32).reshape(-1, 2),
            "stroke_vel": np.asarray(self.stroke_vel, np.float32).reshape(-1, 2),
            "mesh_vertices": mesh.vertices,
            "mesh_triangles": mesh.faces,
            "tess_factors": self.tess_factors(),
        }

    def stats(self) -> dict:
        factors = self.tess_factors()
        visible = factors[:, 3] > 0
        edges = factors[visible, :3]
        density = self.density()
        return {
            **super().stats(),
            "grid": f"{self.params.grid}x{self.params.grid}",
            "variant": self.params.variant,
            "fluid solver": self.fluid.params.solver,
            "max density": float(density.max()),
            "max displacement": float(density.max() * self.params.displacement),
            "patches drawn": int(visible.sum()),
            "edge factors": f"{edges.min():.3g}..{edges.max():.3g}" if len(edges) else "-",
        }

    def export_mesh(self, path) -> None:
        """--mesh: ``mesh()`` as .obj, .ply or .glb."""
        write_mesh(path, self.mesh())

    # }}}


SCENES = [
    Scene(
        "tessellation",
        Simulation,
        "Tessellation + displacement: a plane raised by a painted 2D fluid (vol.4 ch.6)",
        view="View",
        preview={"steps": 240},
        animation=Animation("the brush stroke pushes the displaced fluid surface round", every=3),
        preview_check=PreviewCheck(
            fills_frame="the tessellated height field, seen close, runs out of the frame's sides"
        ),
    )
]
