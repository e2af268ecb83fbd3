"""Projection spray: spray lights paint into each object's texture (vol.1 ch.10; docs/chapters/10-projection-spray.md).

The chapter only shows pictures (a spray device colouring a body, a stencil, a logo) and links the author's sample
(sugi-cho/ProjectionSpray); everything here follows that sample as the chapter page retells it. Each drawable owns a
paint layout (``ugpcl.geometry.uv_atlas``) baked once into per-texel position and normal textures. Every frame:

1. the spray's pose and colour (``aim``: orbit around the objects, fixed, or the point under the mouse) and the
   drawables' transforms (the sample's Rotater spins them about +y);
2. ``SprayDepthClear`` + ``SprayDepthBoxes`` + ``SprayDepth``: the spray's distance map, every drawable's
   triangles cast exactly, one work-item per 16 x 16 block of each triangle's pixel box (the sample rasterises);
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
from dataclasses import dataclass

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..geometry.projection_spray import (
    PRESETS,
    SHAPE_BLOCK_TEXELS,
    Drawable,
    box_blocks,
    look_rotation,
    preset_drawables,
    spray_matrices,
    spray_shape,
)
from ..geometry.transforms import euler_matrix
from ..geometry.uv_atlas import bake, tile_bounds
from ..resources import Allocation
from ..scene import Animation, ParamError, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

TILE = 16
"""Texture tiles are TILE x TILE texels (projection_spray.cl: TILE): the unit of tile skipping."""
DEPTH_BLOCK = 16
"""A SprayDepth work-item casts the pixels of one DEPTH_BLOCK x DEPTH_BLOCK block of a triangle's box
(projection_spray.cl: DEPTH_BLOCK)."""
HUE_RATE = 0.1
"""Hue turns per second while the colour cycles (the sample: HSV((time * 0.1) mod 1, 1, 1))."""
UNIFORM_FLOATS = 64
"""Floats in a drawable's uniform block: O2W, M_proj, W2D (row-major 16 each), colour, emission, range, dt,
occlusion sharpness, occlusion bias (projection_spray.cl: U_*)."""
RECORDED_FRAMES = 36000
"""Per-frame records (spray pose, aim, colour, transforms) kept for the .npz: the last 10 minutes at 60 Hz."""


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
    color: tuple[float, float, float, float] = param(
        (1.0, 0.692, 0.0, 1.0), 0.0, 1e4, live=True, ignored_when={"hue_cycle": True}
    )
    """Spray colour rgba when the hue does not cycle (the sample's material colour)."""
    clear_color: tuple[float, float, float, float] = param((0.0, 0.0, 0.0, 1.0), 0.0, 1e4)
    """Unpainted canvas colour (the sample's scene: black)."""
    painting: bool = param(True, live=True)
    """Spray on (the sample's left mouse button): paint; off: only the guide shows the footprint."""
    aim: str = param("orbit", choices=("orbit", "fixed", "mouse"), live=True)
    """orbit: the spray circles the objects; fixed: it stays at the preset's start; mouse: it looks at ``aim_at``."""
    orbit_period: float = param(8.0, 0.01, 1e4, live=True, used_only_when={"aim": "orbit"})
    """Seconds per revolution of the spray around the objects (aim=orbit)."""
    aim_period: float = param(4.0, 0.01, 1e4, live=True, used_only_when={"aim": "orbit"})
    """Seconds per revolution of the aim point on its circle (aim=orbit)."""
    aim_radius: float = param(3.0, 0.0, 1e3, live=True, used_only_when={"aim": "orbit"})
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


def hsv_color(time: float) -> tuple[float, float, float, float]:
    return (*colorsys.hsv_to_rgb((time * HUE_RATE) % 1.0, 1.0, 1.0), 1.0)


class Simulation(BaseSimulation):
    """Spray lights painting the drawables' textures: depth map, then per drawable paint or guide, then dilation."""

    Params = Params

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program("projection_spray")
        self.shape = rt.to_device(spray_shape(p.shape_res, p.shape_edge, p.shape_freq, p.shape_amp))
        self.depth = rt.zeros(p.depth_res * p.depth_res, np.uint32)
        # GPUs (and Oclgrind, which checks it) cast the depth map in blocks; a CPU device keeps the serial kernel, the
        # same map: there the blocks' extra launch, box read-back and pair list cost 0.3-0.8 ms a frame and save none
        self.blocked_depth = rt.is_gpu or rt.is_oclgrind
        self.rgba8 = rt.zeros(p.tex * p.tex, np.uint32)  # a texture in 8-bit colour, for the view (CanvasToRGBA8)
        self.target = np.asarray(PRESETS[p.preset].aim_center, float)  # aim=mouse: the point under the mouse
        self.records: deque = deque(maxlen=RECORDED_FRAMES)
        try:
            drawables = preset_drawables(p.preset, p.tex, p.edge_texels)
        except ValueError as err:  # the figure's triangles do not fit a texture of tex texels
            raise ParamError(str(err)) from None
        self.set_drawables(drawables)

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
                    "guide_blank": True,  # guide and guide canvas all zero: a guide frame need not clear them
                }
            )
        self.triangles = [d.mesh.vertices[d.mesh.faces].astype(np.float64) for d in drawables]  # (F, 3, 3)
        count = sum(len(t) for t in self.triangles)
        self.world_triangles = rt.zeros((max(count, 1), 3, 4), np.float32)
        self.depth_boxes = rt.zeros((max(count, 1), 4), np.int32)
        self.uniforms = [rt.zeros(UNIFORM_FLOATS, np.float32) for _ in drawables]
        self.all_tiles = rt.to_device(np.arange(self.tiles_x**2, dtype=np.int32))
        self.last = None  # the last frame's pose, uniforms and tiles (guide output for state())
        self.painted_last, self.tiles_last = False, 0
        self.version = 0  # bumped by every frame and clear: the clock of `changed`
        # per drawable, the version at which its canvas and its guide canvas last changed: the view uploads only those
        self.changed = [dict.fromkeys(("canvas", "guide_canvas"), 0) for _ in drawables]

    @classmethod
    def allocations(cls, params: Params) -> list:
        texels, drawables = params.tex**2, 1 if params.preset == "figure" else 2
        return [
            # per drawable: baked positions and normals, paint, canvas, guide and guide canvas (set_drawables)
            Allocation("texture (tex x tex float4)", 16 * texels, "tex", count=6 * drawables),
            Allocation("depth map", params.depth_res**2 * 4, "depth_res"),
            Allocation("8-bit texture for the view", 4 * texels, "tex"),
            Allocation("spray shape", params.shape_res**2 * 16, "shape_res"),
            # host peaks, measured: the spray shape and its noise's float64 temporaries (360-400 bytes a texel, in
            # blocks of SHAPE_BLOCK_TEXELS)
            Allocation(
                "spray shape (host)",
                16 * params.shape_res**2 + 400 * min(params.shape_res**2, SHAPE_BLOCK_TEXELS),
                "shape_res",
                host=True,
            ),
            # a drawable's bake (40 bytes a texel at its peak), the textures it keeps, the state read back (five
            # float4 textures) and written to the .npz: 11.4 GB resident at tex=4096 with two drawables, measured
            Allocation(
                "baked textures and the state read back (host)", 256 * texels, "tex", count=drawables, host=True
            ),
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
        """SprayDepthClear + SprayDepthBoxes + SprayDepth (SprayDepth_serial on a CPU device): the spray's distance map
        of every drawable's triangles."""
        p, queue = self.params, self.runtime.queue
        world = [(t @ m[:3, :3].T + m[:3, 3]) for t, m in zip(self.triangles, o2w, strict=True)]
        count = sum(len(w) for w in world)
        if count:
            packed = np.zeros((count, 3, 4), np.float32)
            packed[..., :3] = np.concatenate(world)
            cl.enqueue_copy(queue, self.world_triangles.data, packed)
        n = p.depth_res * p.depth_res
        self.program.kernel("SprayDepthClear").over(n, 256, self.depth, np.int32(n), np.float32(p.spray_range))
        frame = self.depth_frame(pose)
        if not self.blocked_depth:
            self.program.kernel("SprayDepth_serial").over(count, 64, self.world_triangles, count, self.depth, *frame)
            return
        self.program.kernel("SprayDepthBoxes").over(count, 64, self.world_triangles, count, self.depth_boxes, *frame)
        boxes = np.empty((count, 4), np.int32)
        if count:
            cl.enqueue_copy(queue, boxes, self.depth_boxes.data)
        blocks_x = -(-p.depth_res // DEPTH_BLOCK)
        pairs = box_blocks(boxes, DEPTH_BLOCK, blocks_x)  # (triangle, block): the work-items of SprayDepth
        if not len(pairs):
            return
        self.program.kernel("SprayDepth").over(
            len(pairs),
            64,
            self.world_triangles,
            self.depth_boxes,
            self.runtime.to_device(pairs),
            len(pairs),
            blocks_x,
            self.depth,
            *frame,
        )

    def depth_frame(self, pose: np.ndarray) -> tuple:
        """The depth kernels' last arguments (projection_spray.cl: DEPTH_ARGS): resolution, the spray's origin and
        axes, tan of half its angle, its range."""
        p = self.params
        right, up, forward, origin = (cltypes.make_float4(*pose[:3, k], 0.0) for k in range(4))
        tan_half = np.float32(math.tan(math.radians(p.spray_angle) / 2))
        return np.int32(p.depth_res), origin, right, up, forward, tan_half, np.float32(p.spray_range)

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

    def spray_pass(self, name: str, k: int, tiles, count: int) -> None:
        """SprayDraw (into the paint) or SprayGuide (into the guide) over ``count`` tiles of drawable k."""
        p, tex = self.params, self.textures[k]
        target = tex["paint"] if name == "SprayDraw" else tex["guide"]
        self.program.kernel(name).over(
            count * TILE * TILE,
            TILE * TILE,  # one group per tile; a fixed size also spares PoCL a kernel build per global size
            tiles,
            self.tiles_x,
            p.tex,
            p.tex,
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
        self.program.kernel("EdgeThicken").over(
            count * TILE * TILE,
            TILE * TILE,
            tiles,
            self.tiles_x,
            p.tex,
            p.tex,
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
        self.version += 1
        pose, aim = self.spray_pose(time)
        o2w, color = self.object_to_world(time), self.color(time)
        self.spray_depth(pose, o2w)
        self.last = {"pose": pose, "aim": aim, "o2w": o2w, "color": color, "dt": dt}
        self.tiles_last = 0
        for k in range(len(self.drawables)):
            self._uniforms(k, pose, o2w[k], color, dt)
            self._paint_or_guide(k, pose, o2w[k], painting)
        self.painted_last = painting

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
                self.changed[k]["canvas"] = self.version
            return
        if not (tex["guide_blank"] and spray_count == 0):
            self.changed[k]["guide_canvas"] = self.version
        if not tex["guide_blank"]:
            for name in ("guide", "guide_canvas"):  # the sample's ClearGuid
                cl.enqueue_fill_buffer(queue, tex[name].data, np.float32(0), 0, tex[name].nbytes)
        tex["guide_blank"] = spray_count == 0
        if spray_count:
            self.spray_pass("SprayGuide", k, spray_tiles, spray_count)
            self.edge_thicken(k, "guide", "guide_canvas", dilate_tiles, dilate_count)

    def guide_now(self) -> None:
        """The footprint preview of the last frame's pose (a non-drawing frame; the canvas does not change)."""
        if self.last is None or not self.painted_last:
            return
        last = self.last
        self.version += 1
        self.tiles_last = 0
        for k in range(len(self.drawables)):
            self._paint_or_guide(k, last["pose"], last["o2w"][k], painting=False)
        self.painted_last = False

    def clear(self) -> None:
        """Every canvas back to the clear colour (the viewer's C key)."""
        colour = np.asarray(self.params.clear_color, np.float32)
        self.version += 1
        for tex, changed in zip(self.textures, self.changed, strict=True):
            for name in ("paint", "canvas"):
                cl.enqueue_fill_buffer(self.runtime.queue, tex[name].data, colour, 0, tex[name].nbytes)
            changed["canvas"] = self.version

    # {{{ state

    def _stack(self, name: str) -> np.ndarray:
        return np.stack([t[name].get() for t in self.textures])

    def canvases(self) -> np.ndarray:
        """(n, tex, tex, 4): the paint dilated into the gutters, what the objects show."""
        return self._stack("canvas")

    def guides(self) -> np.ndarray:
        """(n, tex, tex, 4): the dilated footprint preview of the last frame (zero while painting)."""
        return self._stack("guide_canvas")

    def texture_rgba8(self, k: int, name: str) -> np.ndarray:
        """Texture ``name`` (canvas, guide_canvas) of drawable k in 8-bit colour, (tex, tex, 4) uint8: what the view
        shows, converted on the device (CanvasToRGBA8) so that a quarter of the float bytes are read back, into the
        runtime's page-locked copy (``Runtime.read_back``), which the next call overwrites."""
        tex = self.params.tex
        self.program.kernel("CanvasToRGBA8").over(tex * tex, 256, self.textures[k][name], tex * tex, self.rgba8)
        return self.runtime.read_back(self.rgba8).view(np.uint8).reshape(tex, tex, 4)

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


BRIGHT_EMISSION = {"emission": 4.0}
"""The scenes' paint rate: the sample's emission (1 alpha a second) is for a mouse button held as long as one likes;
at 4, the inspector's own knob turned up, a run's first second (60 frames) already shows the paint (at 1 its
brightest texel is 0.47 and the median painted one 0.04 on the black canvas)."""

SCENES = [
    Scene(
        "projection_spray",
        Simulation,
        "Projection spray: a spray light paints the sample's cube and sphere as they turn (vol.1 ch.10)",
        defaults=BRIGHT_EMISSION,
        preview={"steps": 240, "tex": 512, "depth_res": 512},
        interactive={"tex": 384, "depth_res": 256},
        animation=Animation("the spray circles the turning cube and sphere and paints them", every=6, start=30),
    ),
    Scene(
        "projection_spray_stencil",
        Simulation,
        "Projection spray through a stencil plate: the star cut-out is painted on the wall behind (vol.1 ch.10)",
        defaults={"preset": "stencil", "aim": "fixed", "rotation_speed": 0.0, **BRIGHT_EMISSION},
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
            **BRIGHT_EMISSION,
            "clear_color": (0.85, 0.85, 0.85, 1.0),
        },
        preview={"steps": 480, "tex": 1024, "depth_res": 512},
        interactive={"tex": 512, "depth_res": 256},
        preview_check=PreviewCheck(min_subject=0.02, sparse="a slim figure beside the spray's frustum lines"),
    ),
]
