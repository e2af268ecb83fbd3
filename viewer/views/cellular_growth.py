"""Cellular growth views (vol.3 ch.4): coloured discs (the particle shader), white edge lines behind them (the edge
shader, additive) and lit sphere impostors (ParticleSphere.shader of CellularGrowthSphere).

Every frame the particle and edge records of the live prefixes (``live_records``: the pools hand out slots from 0
up, so every live cell and edge is there) go as they are into two shader storage buffers (std430 keeps the 32- and
20-byte layouts); the shaders draw one quad per particle slot and one line per edge slot of those prefixes, instanced
(the book's DrawMeshInstancedIndirect draws the whole capacity), and read their records by instance id. A frame then
moves and draws what lives, not the capacity.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ugpcl.scenes.cellular_growth import PATTERNS

from ..camera import FlatCamera, OrbitCamera
from ..gl import GrowableBuffer, load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView

BOOK_CENTER, BOOK_HALF_HEIGHT = (0.0, 1.0), 10.0
"""The scenes' orthographic camera: size 10 around (0, 1)."""
SPHERE_EYE_DISTANCE, SPHERE_FOV = 50.0, 30.0
"""CellularGrowthSphere's perspective camera: at (0, 1, -50) looking along +z, field of view 30 degrees."""
FIT_MARGIN = 1.1
"""F key and headless PNGs: the live cells' bounding box plus 10 %."""
MIN_FIT_DISCS = 2.5
"""The fit's half-size is at least this many times the largest live disc's half-width: a lone cell (the network's
first seconds) spans 2/5 of the picture's height, clearly a cell, rather than a dot or the whole frame."""
MIN_FIT_HALF = 0.05
"""Smallest half-size the fit zooms in to, world units (cells of radius 0)."""
EDGE_LENGTH = 2.0
"""Edges fade once |pa - pb| exceeds this many times ra + rb (book edge material: _Length)."""
PAN_FRACTION = 0.1
"""Arrow keys move the view by this fraction of its height."""
GROW_STEP = 0.05
"""The + and - keys change grow by this much."""
SSBO_BINDINGS = {"particles": 0, "edges": 1}
"""Storage-buffer binding points (include/cellular_growth.glsl)."""
BUFFER_HEADROOM = 1.5
"""A storage buffer that no longer holds the growing live prefix is made this many times larger."""


@dataclass
class CellCamera(FlatCamera):
    """The scenes' orthographic camera: wheel zooms about the centre, arrow keys pan, F fits the cells."""

    def zoom(self, steps: float) -> None:
        x0, x1, y0, y1 = self.rect
        cx, cy, f = (x0 + x1) / 2, (y0 + y1) / 2, 0.9**steps
        self.rect = (cx + (x0 - cx) * f, cx + (x1 - cx) * f, cy + (y0 - cy) * f, cy + (y1 - cy) * f)

    def pan(self, fx: float, fy: float) -> None:
        x0, x1, y0, y1 = self.rect
        dx, dy = fx * (y1 - y0), fy * (y1 - y0)
        self.rect = (x0 + dx, x1 + dx, y0 + dy, y1 + dy)

    def fit(self, lower, upper, min_half: float = MIN_FIT_HALF) -> None:
        center = (np.asarray(lower) + np.asarray(upper)) / 2
        half = np.maximum((np.asarray(upper) - np.asarray(lower)) / 2 * FIT_MARGIN, min_half)
        self.rect = (center[0] - half[0], center[0] + half[0], center[1] - half[1], center[1] + half[1])


def book_camera() -> CellCamera:
    (cx, cy), h = BOOK_CENTER, BOOK_HALF_HEIGHT
    return CellCamera(rect=(cx - h, cx + h, cy - h, cy + h))


class View(BaseView):
    """The network scene: discs joined by edges (render=edges), discs only, or sphere impostors (V key)."""

    title = "Cellular growth (vol.3 ch.4)"
    background = (0.0, 0.0, 0.0)
    keys = (
        Key("d", "divide now", "divide_now"),
        Key("tab", "divide pattern: closed / branch", "next_pattern"),
        Key("[", "max_link - 1 (2-6)", "fewer_links"),
        Key("]", "max_link + 1 (2-6)", "more_links"),
        Key("+", f"grow + {GROW_STEP}", "faster_growth"),
        Key("-", f"grow - {GROW_STEP}", "slower_growth"),
        Key("i", "iterations per step: 1 / 2 / 3 / 4", "next_iterations"),
        Key("v", "look: discs + edges / discs / spheres", "next_render"),
        Key("g", "repulsion search: all pairs / uniform grid", "next_search"),
        Key("e", "emit emit_count cells at the view centre (or drag the mouse)", "emit_center"),
        Key("f", "fit the view to the cells", "fit"),
        Key("left", "pan left", "pan_left"),
        Key("right", "pan right", "pan_right"),
        Key("up", "pan up", "pan_up"),
        Key("down", "pan down", "pan_down"),
    )
    renders = ("edges", "discs", "spheres")
    max_frame_dt = 1.0 / 30.0

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.disc_program = load_program(ctx, "cellular_growth")
        self.edge_program = load_program(ctx, "cellular_growth_edges")
        self.sphere_program = load_program(ctx, "cellular_growth_sphere")
        corners = np.array([-0.5, -0.5, 0.5, -0.5, -0.5, 0.5, 0.5, 0.5], "f4")
        self.quad = ctx.buffer(corners.tobytes())
        self.disc_vao = ctx.vertex_array(self.disc_program, [(self.quad, "2f", "in_corner")])
        self.sphere_vao = ctx.vertex_array(self.sphere_program, [(self.quad, "2f", "in_corner")])
        self.edge_vao = ctx.vertex_array(self.edge_program, [])
        self.buffers = {name: GrowableBuffer(ctx, BUFFER_HEADROOM, min_bytes=32) for name in SSBO_BINDINGS}
        self.lower, self.upper = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
        self.largest_reach = 0.0
        self.camera = None
        self.alive = self.edge_count = 0

    # {{{ cameras

    def make_camera(self):
        self.camera = book_camera()
        return self.camera

    def png_camera(self):
        if getattr(self.sim.params, "camera", "fit") == "book":
            return book_camera()
        self.upload()
        camera = book_camera()
        camera.fit(self.lower, self.upper, self.min_fit_half())
        return camera

    def min_fit_half(self) -> float:
        """The fit's smallest half-size: MIN_FIT_DISCS largest discs' half-widths (MIN_FIT_HALF at least)."""
        return max(MIN_FIT_DISCS * self.largest_reach, MIN_FIT_HALF)

    # }}}

    # {{{ GL

    def upload(self) -> None:
        parts, edges = self.sim.live_records()  # page-locked prefixes, straight to GL
        self.buffers["particles"].write(parts)
        self.buffers["edges"].write(edges)
        self.count, self.edge_slots = len(parts), len(edges)
        alive = parts["alive"] != 0
        self.alive = int(alive.sum())
        self.edge_count = int((edges["alive"] != 0).sum())
        if self.alive:
            reach = (parts["radius"][alive] * self._size())[:, None]
            self.lower = (parts["position"][alive] - reach).min(axis=0)
            self.upper = (parts["position"][alive] + reach).max(axis=0)
            self.largest_reach = float(reach.max())

    def _size(self) -> float:
        return self.sim.params.size

    def _render(self) -> str:
        return getattr(self.sim.params, "render", "discs")

    def draw(self, camera) -> None:
        for name, binding in SSBO_BINDINGS.items():
            self.buffers[name].buffer.bind_to_storage_buffer(binding)
        render = self._render()
        if render == "spheres":
            self.ctx.enable(moderngl.DEPTH_TEST)
            self.ctx.disable(moderngl.BLEND)
            program = self.sphere_program
            set_camera(program, camera)
            set_uniform(program, "size", self._size())
            set_uniform(program, "depth_from_size", self.sim.params.sphere_depth == "book")
            self.sphere_vao.render(moderngl.TRIANGLE_STRIP, instances=self.count)
            return
        self.ctx.disable(moderngl.DEPTH_TEST)
        self.ctx.enable(moderngl.BLEND)
        if render == "edges" and self.edge_slots:  # edges first, additive (SrcAlpha, One), under the discs
            self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE
            set_camera(self.edge_program, camera)
            set_uniform(self.edge_program, "edge_length", EDGE_LENGTH)
            self.edge_vao.render(moderngl.LINES, vertices=2, instances=self.edge_slots)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        set_camera(self.disc_program, camera)
        set_uniform(self.disc_program, "size", self._size())
        self.disc_vao.render(moderngl.TRIANGLE_STRIP, instances=self.count)
        self.ctx.disable(moderngl.BLEND)

    def status(self) -> list[str]:
        sim, p = self.sim, self.sim.params
        line = f"cells {self.alive}/{sim.count}  pools: particles {sim.particle_pool.count()}"
        if sim.has_edges:
            line = f"cells {self.alive}/{sim.count}  edges {self.edge_count}  pools: particles "
            line += f"{sim.particle_pool.count()}, edges {sim.edge_pool.count()}"
        mode = f"pattern {p.pattern}  max_link {p.max_link}  iterations {p.iterations}  " if sim.has_edges else ""
        return [line, f"{mode}grow {p.grow:g}  search {p.search}  divides {sim.divides}  t = {sim.time:.1f} s"]

    # }}}

    # {{{ mouse: a left drag emits at the cursor (book: EmitParticlesKernel(GetMousePoint()) while held)

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        if isinstance(camera, FlatCamera):
            self.sim.emit_at(camera.to_world(u, v))
        else:
            super().on_drag(camera, u, v, du, dv)

    def on_release(self, camera) -> None:
        self.sim.emit_at(None)

    # }}}

    # {{{ key actions

    def divide_now(self) -> None:
        self.sim.divide()

    def next_pattern(self) -> None:
        p = self.sim.params
        self.sim.update(pattern=PATTERNS[(PATTERNS.index(p.pattern) + 1) % len(PATTERNS)])

    def fewer_links(self) -> None:
        self.sim.update(max_link=max(2, self.sim.params.max_link - 1))

    def more_links(self) -> None:
        self.sim.update(max_link=min(6, self.sim.params.max_link + 1))

    def faster_growth(self) -> None:
        self.sim.update(grow=round(min(1.0, self.sim.params.grow + GROW_STEP), 4))

    def slower_growth(self) -> None:
        self.sim.update(grow=round(max(0.01, self.sim.params.grow - GROW_STEP), 4))

    def next_iterations(self) -> None:
        self.sim.update(iterations=self.sim.params.iterations % 4 + 1)

    def next_render(self) -> None:
        self.sim.update(render=self.renders[(self.renders.index(self._render()) + 1) % len(self.renders)])

    def next_search(self) -> None:
        self.sim.update(search="grid" if self.sim.params.search == "all_pairs" else "all_pairs")

    def emit_center(self) -> None:
        x0, x1, y0, y1 = self.camera.rect if isinstance(self.camera, FlatCamera) else (-1, 1, -1, 1)
        self.sim.emit_particles(((x0 + x1) / 2, (y0 + y1) / 2))

    def fit(self) -> None:
        self.upload()
        if isinstance(self.camera, CellCamera):
            self.camera.fit(self.lower, self.upper, self.min_fit_half())
        elif isinstance(self.camera, OrbitCamera):
            fit_orbit(self.camera, self.lower, self.upper, self.min_fit_half())

    def _pan(self, fx: float, fy: float) -> None:
        if isinstance(self.camera, CellCamera):
            self.camera.pan(fx, fy)

    def pan_left(self) -> None:
        self._pan(-PAN_FRACTION, 0.0)

    def pan_right(self) -> None:
        self._pan(PAN_FRACTION, 0.0)

    def pan_up(self) -> None:
        self._pan(0.0, PAN_FRACTION)

    def pan_down(self) -> None:
        self._pan(0.0, -PAN_FRACTION)

    # }}}


class ParticleView(View):
    """CellularGrowthParticleOnly: discs only; drag the mouse (or press E) to emit cells."""

    title = "Cellular growth, cells only (vol.3 ch.4)"
    keys = tuple(k for k in View.keys if k.key not in ("tab", "[", "]", "i", "v"))

    def _render(self) -> str:
        return "discs"


def fit_orbit(camera: OrbitCamera, lower, upper, min_half: float = MIN_FIT_HALF) -> None:
    """Look at the middle of the box [lower, upper] (z = 0) from far enough to see all of it."""
    center = (np.asarray(lower) + np.asarray(upper)) / 2
    half = max(float(np.max(np.asarray(upper) - np.asarray(lower))) / 2 * FIT_MARGIN, min_half)
    camera.target = (float(center[0]), float(center[1]), 0.0)
    camera.distance = half / np.tan(np.radians(camera.fov / 2))


class SphereView(View):
    """CellularGrowthSphere: the network as lit spheres seen through a perspective camera (drag orbits)."""

    title = "Cellular growth, spheres (vol.3 ch.4)"

    def make_camera(self):
        self.camera = OrbitCamera(target=(0.0, 1.0, 0.0), distance=SPHERE_EYE_DISTANCE, fov=SPHERE_FOV, far=5000.0)
        return self.camera

    def png_camera(self):
        camera = OrbitCamera(target=(0.0, 1.0, 0.0), distance=SPHERE_EYE_DISTANCE, fov=SPHERE_FOV, far=5000.0)
        if self.sim.params.camera == "fit":
            self.upload()
            fit_orbit(camera, self.lower, self.upper, self.min_fit_half())
        return camera
