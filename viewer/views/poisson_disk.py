"""Poisson disk sampling views (vol.4 ch.7): the samples grow from the first point as the sample's coroutine draws
them. 2-D: white discs on black, by a geometry shader that turns each point into a quad (CircleGeometry, fig. 7.7)
or by instancing (V switches; both light the same pixels); 3-D: instanced low-poly spheres (SphereGeometry)."""

from __future__ import annotations

import math

import moderngl
import numpy as np

from ..camera import FlatCamera, OrbitCamera
from ..gl import GrowableBuffer, Lines, load_program, set_camera, set_uniform
from ..meshes import box_edges, uv_sphere
from . import Key
from . import View as BaseView

WHITE = (1.0, 1.0, 1.0, 1.0)
NEWEST = (1.0, 0.55, 0.1, 1.0)
"""The samples the last step kept."""
ACTIVE = (0.2, 0.8, 1.0, 1.0)
CURRENT = (1.0, 0.2, 0.2, 1.0)
"""The active sample the last step threw its candidates around."""
SCIPY = (1.0, 0.15, 0.15, 0.8)
GRID_COLOR = (0.25, 0.25, 0.3, 1.0)
K_CYCLE = (1, 5, 30, 100)
"""What the K key cycles through."""
ANIMATION_STEPS = 2
"""Sampler steps per frame when the scene runs all at once (steps_per_frame = 0): about the sample's one active
point per 0.01 s at 60 frames/s."""
MAX_GRID_LINES = 400
"""The grid overlay is left out beyond this many cells per axis (it would only grey the picture)."""
SPHERE_RINGS, SPHERE_SEGMENTS = 7, 15
"""SphereGeometry's THETA_COUNT and PHI_COUNT."""


class View(BaseView):
    """2-D: discs of radius r * radius_rate / 2; the active list as rings (A), the grid of cells r / sqrt(2) (G)."""

    title = "Poisson disk sampling (vol.4 ch.7)"
    background = (0.0, 0.0, 0.0)
    keys = (
        Key(".", "one sampler step (an active point and its k candidates; gpu: one round of darts)", "sample_once"),
        Key("f", "finish the sampling (and the fill) now", "finish"),
        Key("a", "active list on/off (rings; red: the point of the last step; orange: what it kept)", "toggle_active"),
        Key("g", "background grid on/off (cells r / sqrt(n))", "toggle_grid"),
        Key("v", "discs by geometry shader (fig. 7.7) / by instancing", "toggle_path"),
        Key("m", "method: bridson (host) / gpu (dart throwing)", "next_method"),
        Key("l", "fill the gaps after sampling on/off", "toggle_fill"),
        Key("c", "scipy's PoissonDisk points on top (red) on/off", "toggle_scipy"),
        Key("[", "r / 1.1 (restart)", "smaller_r"),
        Key("]", "r x 1.1 (restart)", "larger_r"),
        Key("k", "k: 1 / 5 / 30 / 100 (restart)", "next_k"),
        Key("+", "twice the sampler steps per frame", "faster"),
        Key("-", "half the sampler steps per frame", "slower"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        if sim.params.steps_per_frame == 0:  # a live parameter: the growth is animated from where the sampler is
            sim.update(steps_per_frame=ANIMATION_STEPS)
        self.show_active, self.show_grid, self.show_scipy = True, False, False
        self.path = "geometry"
        """How discs are drawn: "geometry" (points -> quads in poisson_disk_points.geom) or "instanced"."""
        self.instanced = load_program(ctx, "poisson_disk")
        self.geometry = load_program(ctx, "poisson_disk_points", fragment="poisson_disk")
        self.quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], "f4").tobytes())
        self.layers = {
            name: [GrowableBuffer(ctx, min_bytes=24), 0, None, None] for name in ("discs", "active", "scipy")
        }
        self.grid = Lines(ctx, color=GRID_COLOR)
        self.box = Lines(ctx, color=(0.5, 0.5, 0.5, 1.0))
        self._scipy: np.ndarray | None = None

    def _rect(self) -> tuple[float, float, float, float]:
        (x0, y0), (x1, y1) = self.sim.lo[:2], self.sim.hi[:2]
        margin = 0.04 * max(x1 - x0, y1 - y0)
        return (x0 - margin, x1 + margin, y0 - margin, y1 + margin)

    def make_camera(self):
        return FlatCamera(rect=self._rect())

    # {{{ upload

    def _colors(self, n: int) -> np.ndarray:
        colors = np.tile(np.array(WHITE, "f4"), (n, 1))
        if self.show_active and self.sim.params.method == "bridson" and not self.sim.sampled:
            added = self.sim.stepper.added
            colors[self.sim.stepper.count - added : self.sim.stepper.count] = NEWEST
        return colors

    def _set_layer(self, name: str, centers: np.ndarray, colors: np.ndarray) -> None:
        data = np.column_stack([centers[:, :2], colors]).astype("f4")
        layer = self.layers[name]
        if layer[0].write(data):
            buffer = layer[0].buffer
            layer[2] = self.ctx.vertex_array(
                self.instanced,
                [(self.quad, "2f", "in_corner"), (buffer, "2f 4f/i", "in_center", "in_color")],
            )
            layer[3] = self.ctx.vertex_array(self.geometry, [(buffer, "2f 4f", "in_center", "in_color")])
        layer[1] = len(data)

    def upload(self) -> None:
        points = self.sim.points()
        self._set_layer("discs", points, self._colors(len(points)))
        active = self.sim.active() if self.show_active else np.zeros(0, np.int32)
        colors = np.tile(np.array(ACTIVE, "f4"), (len(active), 1))
        colors[active == self.sim.current()] = CURRENT
        self._set_layer("active", points[active] if len(active) else np.zeros((0, 2)), colors)
        if self.show_scipy:
            if self._scipy is None:
                self._scipy = self.sim.scipy_points()
            self._set_layer("scipy", self._scipy, np.tile(np.array(SCIPY, "f4"), (len(self._scipy), 1)))
        (x0, y0), (x1, y1) = self.sim.lo[:2], self.sim.hi[:2]
        self.box.set([[x0, y0, 0], [x1, y0, 0], [x1, y0, 0], [x1, y1, 0], [x1, y1, 0], [x0, y1, 0], [x0, y1, 0],
                      [x0, y0, 0]])  # fmt: skip
        if self.show_grid:
            self.grid.set(grid_lines(self.sim.lo[:2], self.sim.hi[:2], self.sim.params.r / math.sqrt(2)))

    # }}}

    def draw(self, camera) -> None:
        p = self.sim.params
        camera.rect = self._rect()
        self.ctx.disable(moderngl.DEPTH_TEST)
        if self.show_grid:
            self.grid.draw(camera)
        self.box.draw(camera)
        radius = p.r * p.radius_rate * 0.5
        self.draw_discs("discs", camera, radius)
        if self.show_scipy:
            self.draw_discs("scipy", camera, 0.3 * radius, outline=0.0)
        if self.show_active:
            self.draw_discs("active", camera, max(radius, 0.5 * p.r), outline=0.25)

    def draw_discs(self, name: str, camera, radius: float, outline: float = 0.0) -> None:
        """One layer of discs through the current path: the same quads either way."""
        _, count, instanced_vao, geometry_vao = self.layers[name]
        if not count:
            return
        program = self.geometry if self.path == "geometry" else self.instanced
        set_camera(program, camera)
        set_uniform(program, "radius", float(radius))
        set_uniform(program, "outline", float(outline))
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        if self.path == "geometry":
            geometry_vao.render(moderngl.POINTS, vertices=count)
        else:
            instanced_vao.render(moderngl.TRIANGLE_STRIP, instances=count)
        self.ctx.disable(moderngl.BLEND)

    def status(self) -> list[str]:
        s, p = self.sim, self.sim.params
        steps = "rounds" if p.method == "gpu" else "steps"
        state = "done" if s.done else ("filling" if s.sampled else "sampling")
        return [
            f"N = {len(s.points())}  active {len(s.active())}  {steps} {s.sampler_steps()}  {state}  "
            f"{1e3 * s.seconds:.0f} ms",
            f"method {p.method}  r = {p.r:.3g}  k = {p.k}  fill {'on' if p.fill else 'off'}  discs: {self.path}  "
            f"{p.steps_per_frame} steps/frame",
        ]

    # {{{ key actions

    def sample_once(self) -> None:
        self.sim.sample_step()

    def finish(self) -> None:
        self.sim.finish()

    def toggle_active(self) -> None:
        self.show_active = not self.show_active

    def toggle_grid(self) -> None:
        self.show_grid = not self.show_grid

    def toggle_path(self) -> None:
        self.path = "instanced" if self.path == "geometry" else "geometry"

    def toggle_scipy(self) -> None:
        self.show_scipy = not self.show_scipy

    def _restart(self, **changes) -> None:
        self._scipy = None
        self.sim.update(**changes)
        self.sim.reset()

    def next_method(self) -> None:
        if self.sim.params.dim <= 3:
            self._restart(method="gpu" if self.sim.params.method == "bridson" else "bridson")

    def toggle_fill(self) -> None:
        self._restart(fill=not self.sim.params.fill)

    def smaller_r(self) -> None:
        self._restart(r=self.sim.params.r / 1.1)

    def larger_r(self) -> None:
        self._restart(r=self.sim.params.r * 1.1)

    def next_k(self) -> None:
        k = self.sim.params.k
        self._restart(k=K_CYCLE[(K_CYCLE.index(k) + 1) % len(K_CYCLE)] if k in K_CYCLE else K_CYCLE[0])

    def faster(self) -> None:
        self.sim.update(steps_per_frame=min(self.sim.params.steps_per_frame * 2, 1 << 20))

    def slower(self) -> None:
        self.sim.update(steps_per_frame=max(self.sim.params.steps_per_frame // 2, 1))

    # }}}


def grid_lines(lo, hi, cell: float) -> np.ndarray:
    """Segments of the background grid's cell edges over the box (none beyond MAX_GRID_LINES cells per axis)."""
    (x0, y0), (x1, y1) = lo, hi
    xs, ys = np.arange(x0, x1 + 1e-9, cell), np.arange(y0, y1 + 1e-9, cell)
    if max(len(xs), len(ys)) > MAX_GRID_LINES:
        return np.zeros((0, 3))
    vertical = [[(x, y0, 0), (x, y1, 0)] for x in xs]
    horizontal = [[(x0, y, 0), (x1, y, 0)] for y in ys]
    return np.array(vertical + horizontal, float).reshape(-1, 3)


class View3D(View):
    """3-D: instanced spheres of radius r * radius_rate / 2, shaded; the active samples in blue (A); X cuts the
    cube at z = 0 to show the interior."""

    keys = tuple(k for k in View.keys if k.key not in ("g", "v")) + (
        Key("x", "clipping slab at z = centre on/off (see the interior)", "toggle_clip"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "poisson_disk_sphere")
        vertices, indices = uv_sphere(SPHERE_SEGMENTS, SPHERE_RINGS)
        self.sphere = ctx.buffer(vertices.tobytes())
        self.sphere_indices = ctx.buffer(indices.tobytes())
        self.spheres = GrowableBuffer(ctx, min_bytes=28)
        self.count, self.vao, self.clip = 0, None, False

    def make_camera(self):
        centre = (self.sim.lo[:3] + self.sim.hi[:3]) / 2
        extent = float(np.max(self.sim.hi[:3] - self.sim.lo[:3]))
        return OrbitCamera(target=tuple(centre), distance=2.0 * extent, yaw=30.0, pitch=25.0, near=0.01 * extent,
                           far=10.0 * extent)  # fmt: skip

    def upload(self) -> None:
        points = self.sim.points()[:, :3]
        colors = self._colors(len(points))
        if self.show_active:
            colors[self.sim.active()] = ACTIVE
            if self.sim.current() >= 0 and not self.sim.sampled:
                colors[self.sim.current()] = CURRENT
        if self.spheres.write(np.column_stack([points, colors]).astype("f4")):
            self.vao = self.ctx.vertex_array(
                self.program,
                [(self.sphere, "3f 3f", "in_position", "in_normal"),
                 (self.spheres.buffer, "3f 4f/i", "in_center", "in_color")],
                index_buffer=self.sphere_indices,
            )  # fmt: skip
        self.count = len(points)
        centre, size = (self.sim.lo[:3] + self.sim.hi[:3]) / 2, self.sim.hi[:3] - self.sim.lo[:3]
        self.box.set(box_edges(centre, size))

    def draw(self, camera) -> None:
        p = self.sim.params
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.box.draw(camera)
        if not self.count:
            return
        set_camera(self.program, camera)
        set_uniform(self.program, "radius", p.r * p.radius_rate * 0.5)
        centre = float(self.sim.lo[2] + self.sim.hi[2]) / 2
        set_uniform(self.program, "clip_z", centre if self.clip else float(self.sim.hi[2]) + p.r)
        self.vao.render(moderngl.TRIANGLES, instances=self.count)

    def toggle_clip(self) -> None:
        self.clip = not self.clip
