"""Tessellation + displacement driven by a 2D fluid: Unity's Plane, subdivided on the GPU by edge length and raised
by the fluid's density (vol.4 ch.6 "Tessellation & Displacement"; docs/chapters/17-tessellation.md).

The fluid is a ``stable_fluids_2d`` Simulation this scene owns and drives (vol.4's Solver2D.compute is a stripped
copy of vol.1's): per frame the scripted stroke (or the mouse) holds the brush, the fluid steps, and its density
becomes the displacement texture of the plane. The tessellation itself is GLSL in ``viewer/shaders/tessellation.*``
(TCS: edge-length factors with frustum culling, as Unity's UnityEdgeLengthBasedTessCull; TES: barycentric
interpolation and displacement along the normal). Headless, this module evaluates the same formulas with numpy:
``tess_factors`` (the TCS for the scene camera) and ``displace_plane_grid`` (a uniform grid displaced as the TES
displaces its vertices).

variant=book reproduces the sample: vol.4's stripped solver (no pressure sweeps, no AdvectVelocity; the original's
divergence and back-trace), Point-filtered displacement, lighting with the plane's undisplaced normal (Unity's
surface shader never updates normals after `disp`). variant=fixed (default): vol.1's full solver with Stam's
equations, bilinear displacement, normals of the displaced surface. Both cast the light's shadows through the same
tessellation (the sample's addshadow). Differences from the book in both: Jacobi ping-pong instead of racy in-place
Gauss-Seidel; the plane's normal map (normal.tga, not in the repository) is flat, Unity's "bump" default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..bench.timing import seconds_per_step
from ..geometry.mesh import Mesh, vertex_normals
from ..geometry.mesh_io import write_mesh
from ..geometry.transforms import euler_matrix, perspective
from ..scene import Animation, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation
from .stable_fluids_2d import STROKES
from .stable_fluids_2d import Params as FluidParams
from .stable_fluids_2d import Simulation as FluidSimulation

# {{{ the scene: Unity's built-in Plane, its transform, the camera and the light of FuidTessellation (sic)

PLANE_QUADS = 10
"""Unity's Plane: 10 x 10 quads of 1 unit on x, z in [-5, 5] (11 x 11 vertices, 200 triangles)."""
PLANE_POSITION = (0.0, 1.23, -2.18)
PLANE_EULER = (48.0, 180.0, 0.0)
"""Plane transform in the scene (degrees, Unity's order: z, then x, then y); world normal (0, 0.669, -0.743)."""
CAMERA_POSITION = (0.0, 0.0, -10.0)
"""Scene camera: at (0, 0, -10) looking along +z, vertical FOV 60, clip planes 0.3 and 1000 (Unity's defaults)."""
CAMERA_FOV, CAMERA_NEAR, CAMERA_FAR = 60.0, 0.3, 1000.0
LIGHT_EULER = (80.0, 0.0, 0.0)
"""Directional light rotation; it shines along (0, -0.985, 0.174) with white colour x intensity LIGHT_INTENSITY."""
LIGHT_INTENSITY = 3.2
MAX_TESS_LEVEL = 64.0
"""GL_MAX_TESS_GEN_LEVEL's guaranteed minimum (D3D11: 64); fractional_odd spacing uses up to 63 segments."""


def plane_model() -> np.ndarray:
    """Object-to-world matrix of the plane (scale 1)."""
    model = np.identity(4)
    model[:3, :3] = euler_matrix(*PLANE_EULER)[:3, :3]
    model[:3, 3] = PLANE_POSITION
    return model


def light_direction() -> np.ndarray:
    """Direction the light travels (its forward axis), world space."""
    return euler_matrix(*LIGHT_EULER)[:3, :3] @ np.array([0.0, 0.0, 1.0])


def plane_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Unity's Plane: vertices (121, 12) float32 = position xyz, normal xyz, tangent xyzw, uv; triangles (200, 3).

    uv = ((5 - x)/10, (5 - z)/10): Unity's plane maps its texture opposite to x and z (a texture on an unrotated
    Plane reads upside down), which is why the scene turns it 180 degrees about y; the painting then reads upright
    and lands near the cursor. The tangent follows +u; the normal is +y."""
    n = PLANE_QUADS + 1
    z, x = np.meshgrid(np.linspace(5.0, -5.0, n), np.linspace(5.0, -5.0, n), indexing="ij")  # row j: v = j/10
    vertices = np.zeros((n * n, 12), np.float32)
    vertices[:, 0], vertices[:, 2] = x.ravel(), z.ravel()
    vertices[:, 4] = 1.0  # normal +y
    vertices[:, 6], vertices[:, 9] = -1.0, -1.0  # tangent = d(position)/du = -x; w = -1: binormal = +v = -z
    vertices[:, 10], vertices[:, 11] = (5.0 - x.ravel()) / 10.0, (5.0 - z.ravel()) / 10.0
    triangles = []
    for j in range(PLANE_QUADS):
        for i in range(PLANE_QUADS):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
            triangles += [(a, c, b), (b, c, d)]
    return vertices, np.asarray(triangles, np.int32)


def scene_camera(aspect: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(view, projection, eye) of the scene camera: Unity's left-handed world kept, z mirrored into GL's eye space
    (eye space = (x - cx, y - cy, -(z - cz)) since the camera looks along +z)."""
    view = np.diag([1.0, 1.0, -1.0, 1.0])
    view[:3, 3] = -view[:3, :3] @ np.asarray(CAMERA_POSITION)
    return view, perspective(CAMERA_FOV, aspect, CAMERA_NEAR, CAMERA_FAR), np.asarray(CAMERA_POSITION, float)


# }}}

# {{{ the tessellation formulas in numpy (what the TCS and TES compute)


def frustum_side_planes(view_proj: np.ndarray) -> np.ndarray:
    """Left, right, bottom, top planes (a, b, c, d) of a view-projection matrix, inward, |(a, b, c)| = 1 (Unity's
    unity_CameraWorldClipPlanes[0..3]); a point is inside where a*x + b*y + c*z + d >= 0."""
    m = np.asarray(view_proj, float)
    planes = np.array([m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1]])
    return planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)


def edge_factor(a: np.ndarray, b: np.ndarray, eye, screen_height: float, edge_length: float) -> np.ndarray:
    """UnityCalcEdgeTessFactor: max(|a - b| * screen height / (edge length * distance of the midpoint), 1)."""
    length = np.linalg.norm(a - b, axis=-1)
    distance = np.linalg.norm(0.5 * (a + b) - np.asarray(eye), axis=-1)
    return np.maximum(length * screen_height / (edge_length * distance), 1.0)


def tess_factors(corners: np.ndarray, eye, view_proj, screen_height: float, edge_length: float, displacement: float):
    """UnityEdgeLengthBasedTessCull per triangle: corners (T, 3, 3) world space -> (T, 4) = outer[0..2] (edge
    opposite each corner), inner; all 0 when the triangle lies farther than 1.5 * displacement outside one side
    plane of the frustum."""
    p0, p1, p2 = corners[:, 0], corners[:, 1], corners[:, 2]
    out = np.zeros((len(corners), 4))
    out[:, 0] = edge_factor(p1, p2, eye, screen_height, edge_length)
    out[:, 1] = edge_factor(p2, p0, eye, screen_height, edge_length)
    out[:, 2] = edge_factor(p0, p1, eye, screen_height, edge_length)
    out[:, 3] = out[:, :3].mean(axis=1)
    planes = frustum_side_planes(view_proj)
    distances = np.einsum("tkc,pc->tkp", corners, planes[:, :3]) + planes[:, 3]  # (T, corner, plane)
    culled = np.any(np.all(distances < -1.5 * displacement, axis=1), axis=1)
    out[culled] = 0.0
    return out


def sample_texture(texture: np.ndarray, uv: np.ndarray, linear: bool) -> np.ndarray:
    """GL texture lookup with CLAMP_TO_EDGE of an (h, w) array (row 0 = v near 0): LINEAR (bilinear between texel
    centres at (i + 0.5)/w) or NEAREST (the original's Point filter)."""
    h, w = texture.shape
    t = np.asarray(texture, np.float64)
    x, y = uv[..., 0] * w - 0.5, uv[..., 1] * h - 0.5
    if not linear:
        i = np.clip(np.floor(uv[..., 0] * w).astype(int), 0, w - 1)
        j = np.clip(np.floor(uv[..., 1] * h).astype(int), 0, h - 1)
        return t[j, i]
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0

    def tap(i, j):
        return t[np.clip(j, 0, h - 1), np.clip(i, 0, w - 1)]

    return (1 - fy) * ((1 - fx) * tap(x0, y0) + fx * tap(x0 + 1, y0)) + fy * (
        (1 - fx) * tap(x0, y0 + 1) + fx * tap(x0 + 1, y0 + 1)
    )


def displace_plane_grid(
    density: np.ndarray, level: int, displacement: float, negative: bool = False, linear: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The plane as a uniform (10*level + 1)^2 grid displaced as the TES displaces its vertices: p = p0 + n * d,
    d = density(uv) * displacement (subtracted when negative). Returns world-space vertices (V, 3), triangles (T, 3)
    and the undisplaced world normal (3,)."""
    n = PLANE_QUADS * level + 1
    z, x = np.meshgrid(np.linspace(5.0, -5.0, n), np.linspace(5.0, -5.0, n), indexing="ij")
    uv = np.stack([(5.0 - x) / 10.0, (5.0 - z) / 10.0], axis=-1)
    d = sample_texture(density, uv, linear) * displacement * (-1.0 if negative else 1.0)
    local = np.stack([x, d, z], axis=-1).reshape(-1, 3)  # the normal is +y in object space
    model = plane_model()
    world = local @ model[:3, :3].T + model[:3, 3]
    j, i = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a, b, c, e = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
    triangles = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([b, c, e], -1).reshape(-1, 3)])
    return world.astype(np.float32), triangles.astype(np.int32), model[:3, :3] @ np.array([0.0, 1.0, 0.0])


def plane_corners() -> np.ndarray:
    """World-space corners (200, 3, 3) of the plane's triangles (what the TCS's p0, p1, p2 are)."""
    vertices, triangles = plane_mesh()
    model = plane_model()
    world = vertices[:, :3].astype(np.float64) @ model[:3, :3].T + model[:3, 3]
    return world[triangles]


def fractional_odd_triangles(level: float) -> int:
    """Triangles a triangle patch becomes with every level = ``level`` under fractional_odd spacing: m = the odd
    integer >= level (1..63) segments per edge -> (3 m^2 - 1) / 2 triangles; level <= 0 discards the patch."""
    if level <= 0:
        return 0
    m = min(63, max(1, math.ceil(level)))
    m += 1 - m % 2
    return (3 * m * m - 1) // 2


# }}}


@dataclass(frozen=True)
class Params(BaseParams):
    grid: int = param(256, 8, 4096)
    """Fluid cells per side, a square grid under the square plane (the original: the window >> lod)."""
    diff: float = param(10.0, 0.0, 1e6, live=True)
    """Density diffusion (book: diff; FuidTessellation's Solver).
    Up to 1e6: a <= 1.7e13 keeps the Jacobi sums finite in float32."""
    visc: float = param(100.0, 0.0, 1e6, live=True)
    """Velocity diffusion (book: visc). Up to 1e6: a <= 1.7e13 keeps the Jacobi sums finite in float32."""
    velocity_coef: float = param(4.0, 0.0, 1e4, live=True)
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
    stroke_frames: int = param(0, 0, 1 << 30, live=True)
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

    def _reset(self) -> None:
        self.fluid = FluidSimulation(self.runtime, self.fluid_params(), self.seed)
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


FLUID_KERNEL_BYTES = {
    "AddSourceBrush": 16,  # source written (float4)
    "AddSourceVelocity": 32,  # source.xy read, velocity read and written, prev.xy written
    "DiffuseVelocity": 24,  # velocity_in and prev.xy read, velocity_out written
    "ProjectStep1": {"book": 28, "fixed": 36},  # velocity and prev.z read, prev written; fixed: + divergence, pressure
    "ProjectStep2": {"book": 32, "fixed": 12},  # a Jacobi sweep: prev in and out (float4), or p, div in and p out
    "ProjectStep2Rows": 12,  # the same sweep in strips (fixed only; what GPUs run)
    "ProjectStep3": {"book": 20, "fixed": 24},  # velocity and p read, velocity written; fixed: + prev.x written
    "SwapVelocity": 16,  # velocity read, prev.xy written
    "AdvectVelocity": 16,  # prev.xy read, velocity written
    "AddSourceDensity": 16,  # source.z read, density read and written, prev.z written
    "DiffuseDensity": 12,  # density_in and prev.z read, density_out written
    "SwapDensity": 8,  # density read, prev.z written
    "AdvectDensity": 16,  # velocity and prev.z read, density written
    "AdvectDensityFromExt": 16,  # source.xy and prev.z read, density written
    "Draw": 28,  # velocity and density read, solver (float4) written
}
"""Least memory traffic per cell of each grid kernel of the 2D fluid (clkernels/stable_fluids_2d.cl): the floats of
its own cell it must read and write (the neighbours' from cache; a kernel that keeps part of a float4 writes only
the rest), by the fluid's variant where the layouts differ. The wall launches (SetBoundary*) are not counted."""


def frame_bytes(sim) -> int:
    """Least traffic of one frame of ``sim``'s fluid: one untimed step with the fluid's grid launches counted,
    FLUID_KERNEL_BYTES of each per cell."""
    fluid, counts = sim.fluid, {}
    launch = fluid._grid

    def counted(name: str, *args) -> None:
        counts[name] = counts.get(name, 0) + 1
        launch(name, *args)

    fluid._grid = counted
    try:
        sim.step()
    finally:
        del fluid._grid  # back to the class's method
    variant = fluid.params.variant
    per_cell = 0
    for name, count in counts.items():
        cost = FLUID_KERNEL_BYTES[name]
        per_cell += count * (cost[variant] if isinstance(cost, dict) else cost)
    return per_cell * fluid.w * fluid.h


def bench(runtime, sizes=None) -> list[dict]:
    """Per grid x grid fluid and variant (fixed: vol.1's solver, 22 launches a frame; book: vol.4's stripped copy,
    no pressure sweeps and no AdvectVelocity), circle stroke held: ms per frame (the fluid's step and the stroke's
    bookkeeping, the queue finished after each frame) and fluid cell updates/s; fluid bytes/s = the frame's least
    traffic (frame_bytes: FLUID_KERNEL_BYTES over the launches of one frame) per second. The plane is tessellated
    by GL."""
    sizes = sizes or ([256, 512, 1024] if runtime.is_gpu else [128, 256])
    rows = []
    for n in sizes:
        for variant in ("fixed", "book"):
            sim = Simulation(runtime, Params(grid=n, variant=variant), seed=0)
            seconds = seconds_per_step(sim, min_seconds=1.0, max_steps=100)
            rows.append(
                {
                    "grid": f"{n}^2",
                    "variant": variant,
                    "ms/frame": seconds * 1e3,
                    "cell updates/s": n * n / seconds,
                    "fluid bytes/s": frame_bytes(sim) / seconds,
                }
            )
    return rows


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
