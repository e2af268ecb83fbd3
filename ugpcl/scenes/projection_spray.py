"""Projection spray: spray lights paint into each object's texture (vol.1 ch.10; docs/chapters/10-projection-spray.md).

The chapter only shows pictures (a spray device colouring a body, a stencil, a logo) and links the author's sample
(sugi-cho/ProjectionSpray); everything here follows that sample as the chapter page retells it. Each drawable owns a
paint layout (``ugpcl.geometry.uv_atlas``) baked once into per-texel position and normal textures. Every frame:

1. the spray's pose and colour (``aim``: orbit around the objects, fixed, or the point under the mouse) and the
   drawables' transforms (the sample's Rotater spins them about +y);
2. ``SprayDepthClear`` + ``SprayDepth``: the spray's distance map, every drawable's triangles cast exactly;
3. for every drawable, over the texture tiles the spray cone can reach (ugpcl's, "beyond the book"): ``SprayDraw``
   while painting (``painting``), else ``SprayGuide`` (the footprint preview, cleared every frame);
4. ``EdgeThicken``: the paint (or guide) dilated into the layout's gutters, on those tiles and their neighbours.

Presets: ``cube_sphere`` (the sample's First.unity: a 10-unit cube with a unit sphere on top), ``stencil`` (a plate
with a star cut out between the spray and a wall: Fig 10.3) and ``figure`` (space colonization's procedural figure,
painted through a per-triangle layout: Fig 10.1's body).
"""

from __future__ import annotations

import colorsys
import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..bench.timing import seconds_per_step
from ..geometry.mesh import Mesh, vertex_normals
from ..geometry.mesh_io import write_mesh
from ..geometry.transforms import euler_matrix, perspective, translation
from ..geometry.uv_atlas import bake, per_triangle_layout, tile_bounds, unit_cube, uv_sphere
from ..resources import Allocation
from ..scene import Animation, ParamError, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

TILE = 16
"""Texture tiles are TILE x TILE texels (projection_spray.cl: TILE): the unit of tile skipping."""
SPRAY_NEAR = 0.01
"""The spray's near clip plane (the sample sets it in code)."""
HUE_RATE = 0.1
"""Hue turns per second while the colour cycles (the sample: HSV((time * 0.1) mod 1, 1, 1))."""
UNIFORM_FLOATS = 64
"""Floats in a drawable's uniform block: O2W, M_proj, W2D (row-major 16 each), colour, emission, range, dt,
occlusion sharpness, occlusion bias (projection_spray.cl: U_*)."""
RECORDED_FRAMES = 36000
"""Per-frame records (spray pose, aim, colour, transforms) kept for the .npz: the last 10 minutes at 60 Hz."""
OFFSET = np.array([[0.5, 0, 0, 0.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])
"""Clip xyz -> 0.5 xyz + 0.5 w: clip space to the spray's uv (the sample's projector offset)."""


@dataclass(frozen=True)
class Params(BaseParams):
    preset: str = param("cube_sphere", choices=("cube_sphere", "stencil", "figure"))
    """What is sprayed: the sample's cube and sphere, a wall behind a stencil plate, or the procedural figure."""
    tex: int = param(1024, 16, 8192)
    """Texels per side of every drawable's textures (the sample: texWidth x texHeight 1024)."""
    depth_res: int = param(1024, 16, 8192)
    """Pixels per side of the spray's distance map (the sample: dpthResolution)."""
    shape_res: int = param(256, 16, 4096)
    """Texels per side of the spray-shape texture (the sample bakes SprayTexture once)."""
    spray_angle: float = param(30.0, 1.0, 170.0, live=True)
    """The spray's vertical field of view, degrees, aspect 1 (the sample: sprayAngle)."""
    spray_range: float = param(30.0, 0.02, 1e4, live=True)
    """Far plane and the distance where the paint falls off to 0, units (the sample: splayDistance, _Dst)."""
    emission: float = param(1.0, 0.0, 1e4, live=True)
    """Paint alpha per second (the sample: emission)."""
    hue_cycle: bool = param(True, live=True)
    """Colour = HSV((time * 0.1) mod 1, 1, 1) as the sample sets it every frame; false: ``color``."""
    color: tuple[float, float, float, float] = param((1.0, 0.692, 0.0, 1.0), 0.0, 1e4, live=True)
    """Spray colour rgba when the hue does not cycle (the sample's material colour)."""
    clear_color: tuple[float, float, float, float] = param((0.0, 0.0, 0.0, 1.0), 0.0, 1e4)
    """Unpainted canvas colour (the sample's scene: black)."""
    painting: bool = param(True, live=True)
    """Spray on (the sample's left mouse button): paint; off: only the guide shows the footprint."""
    aim: str = param("orbit", choices=("orbit", "fixed", "mouse"), live=True)
    """orbit: the spray circles the objects; fixed: it stays at the preset's start; mouse: it looks at ``aim_at``."""
    orbit_period: float = param(8.0, 0.01, 1e4, live=True)
    """Seconds per revolution of the spray around the objects (aim=orbit)."""
    aim_period: float = param(4.0, 0.01, 1e4, live=True)
    """Seconds per revolution of the aim point on its circle (aim=orbit)."""
    aim_radius: float = param(3.0, 0.0, 1e3, live=True)
    """Radius of the aim point's circle around the preset's centre, units (aim=orbit)."""
    rotation_speed: float = param(20.0, -3600.0, 3600.0, live=True)
    """Spin of the objects about +y, degrees per second (the sample's Rotater)."""
    occlusion_sharpness: float = param(100.0, 0.01, 1e6, live=True)
    """1 / width of the soft depth compare band, per unit (the sample: 100, a 0.01-unit band)."""
    occlusion_bias: float = param(0.0, -1e3, 1e3, live=True)
    """Subtracted from (distance - depth map) before the compare, units (0 in the sample)."""
    edge_texels: int = param(8, 0, TILE - 1)
    """Dilation distance of EdgeThicken in texels (the sample: 8); below one tile so that new paint only changes
    the canvas in its own and the neighbouring tiles."""
    shape_edge: float = param(0.05, 0.0, 1.0)
    """Soft rim of the spray shape as a fraction of its radius (the sample's material: Edge)."""
    shape_freq: float = param(10.0, 0.0, 1e3)
    """Frequency of the rim noise around the shape (the sample's material: Freq)."""
    shape_amp: float = param(0.01, 0.0, 0.25)
    """Amplitude of the rim noise, in shape uv (the sample's material: Amp)."""
    skip_tiles: bool = param(True, live=True)
    """Run the texel kernels only on tiles the spray cone can reach (ugpcl); false: every texel, as the sample."""


@dataclass
class Drawable:
    """A paintable object: its mesh with a paint layout (uvs), its place, and whether it spins with the Rotater."""

    name: str
    mesh: Mesh
    local: np.ndarray = field(default_factory=lambda: np.identity(4))
    """Object -> parent matrix (uniform scale only: normals go through its 3x3)."""
    rotates: bool = True


@dataclass(frozen=True)
class Preset:
    spray_position: tuple[float, float, float]
    """Start of the spray (aim fixed and mouse), and its orbit's radius and height (aim orbit)."""
    aim_center: tuple[float, float, float]
    """What the spray looks at (aim fixed) and the centre of the aim circle (aim orbit)."""


PRESETS = {
    "cube_sphere": Preset((-4.0, 8.0, -8.0), (0.0, 0.0, 0.0)),  # the sample's spray at (-4, 8, -8)
    "stencil": Preset((0.0, 0.0, -5.0), (0.0, 0.0, 0.0)),
    "figure": Preset((0.0, 1.3, -2.6), (0.0, 0.9, 0.0)),
}
STENCIL_PLATE_Z, STENCIL_PLATE_SIZE = -2.5, 2.4
"""The stencil plate: halfway between the spray (z = -5) and the wall (z = 0), wider than the spray's cone there."""
STAR_RADII, STAR_POINTS = (0.45, 0.2), 5
"""The cut-out: a five-pointed star, outer and inner radius (its shadow on the wall is twice as large)."""
WALL_SIZE = (4.0, 3.0)


# {{{ the presets' objects


def placed(scale: float, offset) -> np.ndarray:
    """The local matrix that scales uniformly by ``scale`` and moves it to ``offset``."""
    return translation(*offset) @ np.diag([scale, scale, scale, 1.0])


def planar_mesh(points2d: np.ndarray, triangles: np.ndarray, z: float) -> Mesh:
    """A flat mesh in the plane z = const facing -z (towards the spray), uvs planar over its bounding box."""
    lo, hi = points2d.min(axis=0), points2d.max(axis=0)
    vertices = np.column_stack([points2d, np.full(len(points2d), z)])
    faces = np.asarray(triangles, np.int64)
    cross = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    faces = np.where((cross[:, 2] > 0)[:, None], faces[:, [0, 2, 1]], faces)  # normal -z
    normals = np.tile([0.0, 0.0, -1.0], (len(points2d), 1))
    return Mesh(vertices, faces, normals, (points2d - lo) / (hi - lo))


def star(outer: float, inner: float, points: int) -> np.ndarray:
    angle = np.pi / 2 + np.arange(2 * points) * np.pi / points
    radius = np.where(np.arange(2 * points) % 2 == 0, outer, inner)
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])


def stencil_plate() -> Mesh:
    """The plate with the star cut out, triangulated by the ear clipper of vol.4 ch.5."""
    from ..geometry.ear_clipping import triangulate

    h = STENCIL_PLATE_SIZE / 2
    outer = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    result = triangulate([outer, star(*STAR_RADII, STAR_POINTS)])
    return planar_mesh(result.vertices, result.triangles, STENCIL_PLATE_Z)


def wall() -> Mesh:
    w, h = WALL_SIZE[0] / 2, WALL_SIZE[1] / 2
    return planar_mesh(np.array([[-w, -h], [w, -h], [w, h], [-w, h]]), [[0, 1, 2], [0, 2, 3]], 0.0)


def figure_mesh(tex: int, gutter: int) -> Mesh:
    from ..geometry.skinned_figure import Figure

    vertices, triangles, _ = Figure().mesh()
    mesh = Mesh(vertices, triangles, vertex_normals(vertices, triangles))
    return per_triangle_layout(mesh, tex, gutter)


def island_gutter(tex: int, edge_texels: int) -> int:
    """Texels between an island and its cell's border: 16 or twice the dilation (the sample's lightmap padding),
    at most tex / 24 so that small test textures keep islands of a few texels."""
    return max(1, min(max(16, 2 * edge_texels), tex // 24))


def preset_drawables(p: Params) -> list[Drawable]:
    gutter = island_gutter(p.tex, p.edge_texels)
    if p.preset == "cube_sphere":
        cube, sphere = unit_cube(p.tex, gutter), uv_sphere(p.tex, gutter)
        return [Drawable("cube", cube, placed(10.0, (0, -5, 0))), Drawable("sphere", sphere, placed(2.0, (0, 1, 0)))]
    if p.preset == "stencil":
        return [Drawable("wall", wall(), rotates=False), Drawable("plate", stencil_plate(), rotates=False)]
    try:
        return [Drawable("figure", figure_mesh(p.tex, p.edge_texels // 2 + 1))]
    except ValueError as err:
        raise ParamError(str(err)) from None


# }}}

# {{{ spray shape and pose


def snoise2d(v: np.ndarray) -> np.ndarray:
    """Ashima's 2-D simplex noise (webgl-noise, MIT; Keijiro's SimplexNoise2D.cginc), about [-1, 1]."""
    c = np.array([0.211324865405187, 0.366025403784439, -0.577350269189626, 0.024390243902439])
    mod289 = lambda x: x - np.floor(x / 289.0) * 289.0  # noqa: E731
    permute = lambda x: mod289((x * 34.0 + 1.0) * x)  # noqa: E731
    i = np.floor(v + (v[..., 0] + v[..., 1])[..., None] * c[1])
    x0 = v - i + (i[..., 0] + i[..., 1])[..., None] * c[0]
    i1 = np.where((x0[..., 0] > x0[..., 1])[..., None], [1.0, 0.0], [0.0, 1.0])
    x1 = x0 + c[0] - i1
    x2 = x0 + c[2]
    i = mod289(i)
    p = permute(
        permute(i[..., 1, None] + np.stack([np.zeros_like(i1[..., 1]), i1[..., 1], np.ones_like(i1[..., 1])], -1))
        + i[..., 0, None]
        + np.stack([np.zeros_like(i1[..., 0]), i1[..., 0], np.ones_like(i1[..., 0])], -1)
    )
    corners = np.stack([x0, x1, x2], -2)
    m = np.maximum(0.5 - np.sum(corners**2, -1), 0.0) ** 4
    x = 2.0 * np.modf(p * c[3])[0] - 1.0
    x = np.where(x < -1.0, x + 2.0, x)  # fract of a negative number
    h = np.abs(x) - 0.5
    a0 = x - np.floor(x + 0.5)
    m *= 1.79284291400159 - 0.85373472095314 * (a0 * a0 + h * h)
    g = a0 * corners[..., 0] + h * corners[..., 1]
    return 130.0 * np.sum(m * g, -1)


def spray_shape(res: int, edge: float, freq: float, amp: float) -> np.ndarray:
    """The spray's footprint (the sample's SprayPaintTexGen): rgb = 1, alpha = a soft disc of radius ~0.5 whose rim
    wobbles with simplex noise around the circle; (res, res, 4) float32, alpha 1 at the centre."""
    centres = (np.arange(res) + 0.5) / res - 0.5
    xy = np.stack(np.meshgrid(centres, centres), -1)
    d = np.linalg.norm(xy, axis=-1)
    direction = xy / np.maximum(d, 1e-12)[..., None]
    radius = 0.5 - amp + amp * snoise2d(direction * freq)
    lo, hi = radius * (1.0 - edge), radius
    t = np.clip((d - lo) / np.maximum(hi - lo, 1e-12), 0.0, 1.0)
    alpha = np.where(d >= hi, 0.0, 1.0 - t * t * (3.0 - 2.0 * t))
    alpha = np.where(d <= lo, 1.0, alpha)
    shape = np.ones((res, res, 4), np.float32)
    shape[..., 3] = alpha
    return shape


def look_rotation(position, target) -> np.ndarray:
    """Unity's LookAt with world up: the spray's local -> world matrix, local +z towards ``target``."""
    position, target = np.asarray(position, float), np.asarray(target, float)
    forward = target - position
    forward /= np.linalg.norm(forward)
    up = np.array([0.0, 1.0, 0.0])
    right = np.cross(up, forward)
    if np.linalg.norm(right) < 1e-9:  # aiming straight up or down: LookAt is singular, take world +z as up
        right = np.cross([0.0, 0.0, 1.0], forward)
    right /= np.linalg.norm(right)
    m = np.identity(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(forward, right), forward, position
    return m


def spray_matrices(pose: np.ndarray, angle: float, spray_range: float) -> tuple[np.ndarray, np.ndarray]:
    """(M_proj, W2D) of a spray at ``pose``: world -> spray uv (Offset P V, V looking down -z) and world -> local."""
    w2d = np.linalg.inv(pose)
    view = np.diag([1.0, 1.0, -1.0, 1.0]) @ w2d
    return OFFSET @ perspective(angle, 1.0, SPRAY_NEAR, spray_range) @ view, w2d


def hsv_color(time: float) -> tuple[float, float, float, float]:
    return (*colorsys.hsv_to_rgb((time * HUE_RATE) % 1.0, 1.0, 1.0), 1.0)


# }}}


class Simulation(BaseSimulation):
    """Spray lights painting the drawables' textures: depth map, then per drawable paint or guide, then dilation."""

    Params = Params

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program("projection_spray")
        self.shape = rt.to_device(spray_shape(p.shape_res, p.shape_edge, p.shape_freq, p.shape_amp))
        self.depth = rt.zeros(p.depth_res * p.depth_res, np.uint32)
        self.target = np.asarray(PRESETS[p.preset].aim_center, float)  # aim=mouse: the point under the mouse
        self.records: deque = deque(maxlen=RECORDED_FRAMES)
        self.set_drawables(preset_drawables(p))

    def set_drawables(self, drawables: list[Drawable]) -> None:
        """Bake and upload ``drawables`` (tests and experiments place their own objects); canvases start clear."""
        p, rt = self.params, self.runtime
        self.drawables = drawables
        self.textures = []
        clear = np.broadcast_to(np.asarray(p.clear_color, np.float32), (p.tex, p.tex, 4))
        for d in drawables:
            pos, nrm, _, _ = bake(d.mesh, p.tex)
            centres, radii = tile_bounds(pos, TILE)
            self.textures.append(
                {
                    "pos_tex": rt.to_device(pos),
                    "nrm_tex": rt.to_device(nrm),
                    "paint": rt.to_device(clear),
                    "canvas": rt.to_device(clear),
                    "guide": rt.zeros((p.tex, p.tex, 4), np.float32),
                    "guide_canvas": rt.zeros((p.tex, p.tex, 4), np.float32),
                    "tile_centres": centres,
                    "tile_radii": radii,
                    "pos": pos,
                }
            )
        self.triangles = [d.mesh.vertices[d.mesh.faces].astype(np.float64) for d in drawables]  # (F, 3, 3)
        count = sum(len(t) for t in self.triangles)
        self.world_triangles = rt.zeros((max(count, 1), 3, 4), np.float32)
        self.uniforms = [rt.zeros(UNIFORM_FLOATS, np.float32) for _ in drawables]
        self.all_tiles = rt.to_device(np.arange(self.tiles_x**2, dtype=np.int32))
        self.last = None  # the last frame's pose, uniforms and tiles (guide output for state())
        self.painted_last, self.tiles_last = False, 0
        self.version = 0  # bumped whenever a texture changes: the view uploads only then

    @classmethod
    def allocations(cls, params: Params) -> list:
        texture = params.tex * params.tex * 16
        return [
            Allocation("texture (tex x tex float4)", texture, "tex"),
            Allocation("depth map", params.depth_res**2 * 4, "depth_res"),
            Allocation("spray shape", params.shape_res**2 * 16, "shape_res"),
        ]

    @property
    def tiles_x(self) -> int:
        return -(-self.params.tex // TILE)

    # {{{ pose

    def aim_at(self, point) -> None:
        """Point the spray at ``point`` (world) from the preset's start (aim=mouse: the viewer's mouse hit)."""
        self.target = np.asarray(point, float)

    def spray_pose(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """(spray local -> world matrix, aim point) at ``time``."""
        p, preset = self.params, PRESETS[self.params.preset]
        start, centre = np.asarray(preset.spray_position), np.asarray(preset.aim_center)
        if p.aim == "fixed":
            return look_rotation(start, centre), centre
        if p.aim == "mouse":
            return look_rotation(start, self.target), self.target
        offset = start - centre
        radius, start_angle = math.hypot(offset[0], offset[2]), math.atan2(offset[2], offset[0])
        spin = start_angle + 2 * math.pi * time / p.orbit_period
        position = centre + np.array([radius * math.cos(spin), offset[1], radius * math.sin(spin)])
        phase = 2 * math.pi * time / p.aim_period
        target = centre + p.aim_radius * np.array([math.cos(phase), 0.0, math.sin(phase)])
        return look_rotation(position, target), target

    def object_to_world(self, time: float) -> np.ndarray:
        """(n, 4, 4): every drawable's transform at ``time`` (the Rotater spins its children about +y)."""
        spin = euler_matrix(0.0, self.params.rotation_speed * time, 0.0)
        return np.stack([spin @ d.local if d.rotates else d.local for d in self.drawables])

    def color(self, time: float) -> tuple[float, float, float, float]:
        return hsv_color(time) if self.params.hue_cycle else self.params.color

    # }}}

    # {{{ kernels, in the sample's order

    def spray_depth(self, pose: np.ndarray, o2w: np.ndarray) -> None:
        """SprayDepthClear + SprayDepth: the spray's distance map of every drawable's triangles."""
        p = self.params
        world = [(t @ m[:3, :3].T + m[:3, 3]) for t, m in zip(self.triangles, o2w, strict=True)]
        count = sum(len(w) for w in world)
        if count:
            packed = np.zeros((count, 3, 4), np.float32)
            packed[..., :3] = np.concatenate(world)
            cl.enqueue_copy(self.runtime.queue, self.world_triangles.data, packed)
        n = p.depth_res * p.depth_res
        self.program.kernel("SprayDepthClear").over(n, 256, self.depth, np.int32(n), np.float32(p.spray_range))
        axes = [cltypes.make_float4(*pose[:3, k], 0.0) for k in range(4)]  # right, up, forward, origin
        self.program.kernel("SprayDepth").over(
            count,
            64,
            self.world_triangles,
            np.int32(count),
            self.depth,
            np.int32(p.depth_res),
            axes[3],
            axes[0],
            axes[1],
            axes[2],
            np.float32(math.tan(math.radians(p.spray_angle) / 2)),
            np.float32(p.spray_range),
        )

    def reachable_tiles(self, k: int, pose: np.ndarray, o2w: np.ndarray) -> np.ndarray:
        """Tiles of drawable k holding a texel the spray can reach: its covered texels' bounding sphere meets the
        cone around the spray's frustum (half angle to the frustum's corners) within range; (n_tiles,) bool."""
        p, tex = self.params, self.textures[k]
        radii = tex["tile_radii"] * np.cbrt(abs(np.linalg.det(o2w[:3, :3])))
        centres = tex["tile_centres"] @ o2w[:3, :3].T + o2w[:3, 3] - pose[:3, 3]
        distance = np.linalg.norm(centres, axis=1)
        cosine = np.clip(centres @ pose[:3, 2] / np.maximum(distance, 1e-30), -1.0, 1.0)
        half = math.atan(math.tan(math.radians(p.spray_angle) / 2) * math.sqrt(2.0))
        widen = np.arcsin(np.clip(radii / np.maximum(distance, 1e-30), 0.0, 1.0))
        inside = (distance <= radii) | ((np.arccos(cosine) - widen <= half) & (distance - radii <= p.spray_range))
        return (radii >= 0) & inside

    def _tile_list(self, mask: np.ndarray):
        return self.runtime.to_device(np.flatnonzero(mask).astype(np.int32)) if mask.any() else None

    def _uniforms(self, k: int, pose, o2w, color, dt: float) -> None:
        p = self.params
        proj, w2d = spray_matrices(pose, p.spray_angle, p.spray_range)
        block = np.zeros(UNIFORM_FLOATS, np.float32)
        block[0:16], block[16:32], block[32:48] = o2w.ravel(), proj.ravel(), w2d.ravel()
        block[48:52] = color
        block[52:57] = p.emission, p.spray_range, dt, p.occlusion_sharpness, p.occlusion_bias
        self.uniforms[k].set(block)

    def _over_tiles(self, name: str, tiles, count: int, *args) -> None:
        """Launch ``name`` with one work-group per tile of the list ``tiles`` (its first ``count``), then ``args``."""
        tex = np.int32(self.params.tex)
        self.program.kernel(name)(
            (count * TILE * TILE,),
            (TILE * TILE,),  # one group per tile; a fixed size also spares PoCL a kernel build per global size
            tiles,
            np.int32(self.tiles_x),
            tex,
            tex,
            *args,
        )

    def spray_pass(self, name: str, k: int, tiles, count: int) -> None:
        """SprayDraw (into the paint) or SprayGuide (into the guide) over ``count`` tiles of drawable k."""
        p, tex = self.params, self.textures[k]
        target = tex["paint"] if name == "SprayDraw" else tex["guide"]
        self._over_tiles(
            name,
            tiles,
            count,
            tex["pos_tex"],
            tex["nrm_tex"],
            self.shape,
            np.int32(p.shape_res),
            self.depth,
            np.int32(p.depth_res),
            self.uniforms[k],
            target,
        )

    def edge_thicken(self, k: int, source: str, target: str, tiles, count: int) -> None:
        """EdgeThicken: ``source`` dilated into the gutters -> ``target`` on ``count`` tiles of drawable k."""
        p, tex = self.params, self.textures[k]
        self._over_tiles(
            "EdgeThicken",
            tiles,
            count,
            tex["pos_tex"],
            np.int32(p.edge_texels),
            tex[source],
            tex[target],
        )

    # }}}

    def _step(self, dt: float) -> None:
        self.frame(self.time, dt, self.params.painting)
        self.records.append((self.last["pose"], self.last["aim"], self.last["color"], self.last["o2w"]))

    def frame(self, time: float, dt: float, painting: bool) -> None:
        """One frame of the sample's DrawingManager at ``time``: pose, depth map, paint or guide, dilation."""
        pose, aim = self.spray_pose(time)
        o2w, color = self.object_to_world(time), self.color(time)
        self.spray_depth(pose, o2w)
        self.last = {"pose": pose, "aim": aim, "o2w": o2w, "color": color, "dt": dt}
        self.tiles_last = 0
        for k in range(len(self.drawables)):
            self._uniforms(k, pose, o2w[k], color, dt)
            self._paint_or_guide(k, pose, o2w[k], painting)
        self.painted_last = painting
        self.version += 1

    def _paint_or_guide(self, k: int, pose, o2w, painting: bool) -> None:
        tex, n = self.textures[k], self.tiles_x
        if self.params.skip_tiles:
            reach = self.reachable_tiles(k, pose, o2w)
            grid = np.pad(reach.reshape(n, n), 1)  # and the tiles next to them: dilation reaches one tile
            ring = np.zeros((n, n), bool)
            for dy in range(3):
                for dx in range(3):
                    ring |= grid[dy : dy + n, dx : dx + n]
            spray_tiles, spray_count = self._tile_list(reach), int(reach.sum())
            dilate_tiles, dilate_count = self._tile_list(ring.ravel()), int(ring.sum())
        else:
            spray_tiles = dilate_tiles = self.all_tiles
            spray_count = dilate_count = n * n
        self.tiles_last += spray_count
        queue = self.runtime.queue
        if painting:
            if spray_count:
                self.spray_pass("SprayDraw", k, spray_tiles, spray_count)
                self.edge_thicken(k, "paint", "canvas", dilate_tiles, dilate_count)
            return
        for name in ("guide", "guide_canvas"):  # the sample's ClearGuid
            cl.enqueue_fill_buffer(queue, tex[name].data, np.float32(0), 0, tex[name].nbytes)
        if spray_count:
            self.spray_pass("SprayGuide", k, spray_tiles, spray_count)
            self.edge_thicken(k, "guide", "guide_canvas", dilate_tiles, dilate_count)

    def guide_now(self) -> None:
        """The footprint preview of the last frame's pose (a non-drawing frame; the canvas does not change)."""
        if self.last is None or not self.painted_last:
            return
        last = self.last
        self.tiles_last = 0
        for k in range(len(self.drawables)):
            self._paint_or_guide(k, last["pose"], last["o2w"][k], painting=False)
        self.painted_last = False
        self.version += 1

    def clear(self) -> None:
        """Every canvas back to the clear colour (the viewer's C key)."""
        colour = np.asarray(self.params.clear_color, np.float32)
        for tex in self.textures:
            for name in ("paint", "canvas"):
                cl.enqueue_fill_buffer(self.runtime.queue, tex[name].data, colour, 0, tex[name].nbytes)
        self.version += 1

    # {{{ state

    def _stack(self, name: str) -> np.ndarray:
        return np.stack([t[name].get() for t in self.textures])

    def canvases(self) -> np.ndarray:
        """(n, tex, tex, 4): the paint dilated into the gutters, what the objects show."""
        return self._stack("canvas")

    def guides(self) -> np.ndarray:
        """(n, tex, tex, 4): the dilated footprint preview of the last frame (zero while painting)."""
        return self._stack("guide_canvas")

    def depth_map(self) -> np.ndarray:
        d = self.params.depth_res
        return self.depth.get().view(np.float32).reshape(d, d)

    def state(self) -> dict[str, np.ndarray]:
        self.guide_now()
        n = len(self.drawables)
        records = list(self.records)
        frames = len(records)
        return {
            "canvas": self.canvases(),
            "paint": self._stack("paint"),
            "guide": self.guides(),
            "pos_tex": np.stack([t["pos"] for t in self.textures]),
            "nrm_tex": self._stack("nrm_tex"),
            "depth_map": self.depth_map(),
            "spray_pose": np.array([r[0] for r in records], np.float32).reshape(frames, 4, 4),
            "aim_points": np.array([r[1] for r in records], np.float32).reshape(frames, 3),
            "colors": np.array([r[2] for r in records], np.float32).reshape(frames, 4),
            "o2w": np.array([r[3] for r in records], np.float32).reshape(frames, n, 4, 4),
            "drawable_names": np.array([d.name for d in self.drawables]),
        }

    def stats(self) -> dict:
        p = self.params
        covered = np.stack([t["pos"][..., 3] >= 0.5 for t in self.textures])
        painted = np.any(self._stack("paint") != np.asarray(p.clear_color, np.float32), axis=-1) & covered
        return {
            **super().stats(),
            "drawables": len(self.drawables),
            "triangles": sum(len(t) for t in self.triangles),
            "painted fraction": float(painted.sum() / max(covered.sum(), 1)),
            "tiles sprayed last frame": f"{self.tiles_last} of {len(self.drawables) * self.tiles_x**2}",
        }

    # }}}

    # {{{ geometry

    def mesh(self) -> Mesh:
        """Every drawable in world space at the current time, uvs into an atlas of the canvases side by side
        (drawable k covers u in [k, k + 1] / n)."""
        o2w, n = self.object_to_world(self.time), len(self.drawables)
        parts = []
        for k, (d, m) in enumerate(zip(self.drawables, o2w, strict=True)):
            normals = d.mesh.normals @ m[:3, :3].T
            normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
            uvs = (d.mesh.uvs + [k, 0.0]) / [n, 1.0]
            parts.append(Mesh(d.mesh.vertices @ m[:3, :3].T + m[:3, 3], d.mesh.faces, normals, uvs))
        return Mesh.merge(parts)

    def texture_atlas(self) -> np.ndarray:
        """(tex, n * tex, 4) uint8, row 0 at the top: the canvases side by side, as an image file stores them."""
        canvas = np.concatenate(list(self.canvases()), axis=1)[::-1]
        return np.round(np.clip(canvas, 0.0, 1.0) * 255).astype(np.uint8)

    def export_mesh(self, path) -> None:
        """.glb: the painted objects with the canvas atlas as their base colour texture; .obj/.ply: the geometry."""
        from pathlib import Path

        path = Path(path)
        if path.suffix.lower() != ".glb":
            write_mesh(path, self.mesh())
            return
        import trimesh
        from PIL import Image

        mesh = self.mesh()
        material = trimesh.visual.material.PBRMaterial(baseColorTexture=Image.fromarray(self.texture_atlas()))
        visual = trimesh.visual.TextureVisuals(uv=mesh.uvs, material=material)
        body = trimesh.Trimesh(mesh.vertices, mesh.faces, vertex_normals=mesh.normals, visual=visual, process=False)
        path.write_bytes(trimesh.Scene(body).export(file_type="glb"))

    # }}}


SPRAY_TEXEL_BYTES = 80
"""Least memory traffic per texel of a sprayed tile, float4 texels: SprayDraw reads pos_tex and nrm_tex (32; the
spray's depth map and shape come from cache) and EdgeThicken reads pos_tex and the paint and writes the canvas (48).
The ring of tiles EdgeThicken adds around the sprayed ones and the depth map's pass are not counted."""

PAINT_TEXEL_BYTES = 32
"""What a texel the paint changes adds: SprayDraw reads and writes its paint texel (16 each)."""


def bench(runtime, sizes=None) -> list[dict]:
    """Painted texels/s: one frame (depth map, SprayDraw, EdgeThicken) per step, spraying 1 or 8 unit spheres
    (bench_spheres) from 12 units, per texture size, with and without tile skipping. texels/s counts every texel
    the sample's passes touch (objects x tex^2 per frame); painted texels/s only those the paint changed.
    frame bytes/s: SPRAY_TEXEL_BYTES per texel of the tiles sprayed and PAINT_TEXEL_BYTES per painted texel, per
    second."""
    sizes = sizes or ([1024, 2048] if runtime.is_gpu else [128, 256])
    rows = []
    for tex in sizes:
        for objects in (1, 8):
            for skip in (False, True):
                params = Params(
                    tex=tex, depth_res=min(tex, 1024), hue_cycle=False, rotation_speed=0.0, aim="fixed", skip_tiles=skip
                )
                sim = Simulation(runtime, params, seed=0)
                sim.set_drawables(bench_spheres(tex, objects, params.edge_texels))
                before = np.stack([t["paint"].get() for t in sim.textures])
                sim.step()
                painted = int(np.any(np.stack([t["paint"].get() for t in sim.textures]) != before, axis=-1).sum())
                seconds = seconds_per_step(sim, max_steps=20)
                rows.append(
                    {
                        "tex": tex,
                        "objects": objects,
                        "skip tiles": skip,
                        "ms/frame": seconds * 1e3,
                        "texels/s": objects * tex * tex / seconds,
                        "painted texels/s": painted / seconds,
                        "tiles sprayed": sim.tiles_last,
                        "frame bytes/s": (
                            SPRAY_TEXEL_BYTES * sim.tiles_last * TILE * TILE + PAINT_TEXEL_BYTES * painted
                        )
                        / seconds,
                    }
                )
    return rows


def bench_spheres(tex: int, count: int, edge_texels: int) -> list[Drawable]:
    """``count`` (<= 9) unit spheres 4 units apart on a 3-wide grid around the cube_sphere spray's aim centre: the outer
    ones lie only partly in its cone."""
    sphere = uv_sphere(tex, island_gutter(tex, edge_texels))
    grid = sorted(((x * 4.0, y * 4.0, 0.0) for y in (-1, 0, 1) for x in (-1, 0, 1)), key=np.linalg.norm)
    spots = grid[:count]  # the centre first: one sphere is the one the spray points at
    return [Drawable(f"sphere{i}", sphere, placed(1.0, spot), rotates=False) for i, spot in enumerate(spots)]


SCENES = [
    Scene(
        "projection_spray",
        Simulation,
        "Projection spray: a spray light paints the sample's cube and sphere as they turn (vol.1 ch.10)",
        preview={"steps": 240, "tex": 512, "depth_res": 512},
        interactive={"tex": 384, "depth_res": 256},
        animation=Animation("the spray circles the turning cube and sphere and paints them", every=6, start=30),
    ),
    Scene(
        "projection_spray_stencil",
        Simulation,
        "Projection spray through a stencil plate: the star cut-out is painted on the wall behind (vol.1 ch.10)",
        defaults={"preset": "stencil", "aim": "fixed", "rotation_speed": 0.0},
        preview={"steps": 90, "tex": 512, "depth_res": 512},
        interactive={"tex": 384, "depth_res": 256},
    ),
    Scene(
        "projection_spray_figure",
        Simulation,
        "Projection spray on the procedural figure through a per-triangle texture layout (vol.1 ch.10)",
        defaults={
            "preset": "figure",
            "rotation_speed": 0.0,
            "aim_radius": 0.35,
            "edge_texels": 2,
            "emission": 4.0,
            "clear_color": (0.85, 0.85, 0.85, 1.0),
        },
        preview={"steps": 480, "tex": 1024, "depth_res": 512},
        interactive={"tex": 512, "depth_res": 256},
        preview_check=PreviewCheck(min_subject=0.02, sparse="a slim figure beside the spray's frustum lines"),
    ),
]
