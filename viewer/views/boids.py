"""Boids view (vol.1 ch.3, BoidsRender): one cube mesh drawn instanced per boid, oriented by its velocity."""

from __future__ import annotations

import dataclasses
import itertools

import moderngl
import numpy as np

from ..camera import OrbitCamera
from ..gl import GrowableBuffer, Lines, load_program, set_camera, set_uniform
from ..meshes import box_edges, cube
from . import Key
from . import View as BaseView

MIN_BOIDS, MAX_BOIDS = 256, 262144
"""Range of the [ and ] keys (halving/doubling N, multiples of 256)."""
PICTURE_YAW, PICTURE_PITCH = -30.0, 15.0
"""Where pictures look from: in front of the box, a little to the left and above."""
CAGE_MARGIN = 0.98
"""The cage is drawn in a close-up only where every corner projects within this share of the half-frame."""
FIT_POINTS = 65536
"""Above this many boids a picture frames the corners of their bounding box instead of every boid: the box holds
them all, so they all stay in the frame (a frame is a convex set), and refitting a million points each frame cost
300 ms on the H200 machine's host."""
POINT_BOIDS = 65536
"""Above this many boids each is drawn as a point (boids_points.vert) instead of a cube: a flock that large is a
pixel or two a boid on screen, and 36 vertices a boid held a million-boid frame at 61 ms on the lent H200."""
CLOSE_UP_FILL = 0.6
"""Share of the half-frame the boids fill in a close-up (``OrbitCamera.fit``): room around a ball of boids, and a
camera far enough that the near ones are not much larger than the far ones."""


@dataclasses.dataclass
class PictureCamera(OrbitCamera):
    """The camera of pictures and videos (``View.png_camera``): the view frames it on the boids before every frame
    (``View.frame``), so a video follows the book's start, a ball of radius 1, as it spreads into the 32^3 box."""

    shows_cage: bool = True
    """Whether the wall box fits in the frame (else the close-up leaves it out: its lines would cross the edge)."""


class View(BaseView):
    title = "Boids (vol.1 ch.3)"
    keys = (
        Key("[", "halve the number of boids", "fewer_boids"),
        Key("]", "double the number of boids", "more_boids"),
        Key("+", "separate_weight + 0.5", "more_separation"),
        Key("-", "separate_weight - 0.5", "less_separation"),
        Key("1", "separation on/off", "toggle_separation"),
        Key("2", "alignment on/off", "toggle_alignment"),
        Key("3", "cohesion on/off", "toggle_cohesion"),
        Key("tab", "ForceCS variant: auto / tiled / lanes / naive / grid", "next_variant"),
        Key("b", "wall box on/off", "toggle_box"),
        Key("c", "colour by speed on/off", "toggle_colors"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "boids")
        self.point_program = load_program(ctx, "boids", vertex="boids_points")
        vertices, indices = cube()
        self.mesh_vbo = ctx.buffer(vertices.tobytes())
        self.mesh_ibo = ctx.buffer(indices.tobytes())
        self.instances = GrowableBuffer(ctx)
        self.points = GrowableBuffer(ctx)  # a large flock's half-float copy (PackBoidsHalf)
        self.box = Lines(ctx, color=(0.0, 1.0, 1.0, 1.0))
        self.show_box, self.color_by_speed = True, False
        self.saved_weights: dict[str, float] = {}
        self.positions = None  # what pictures frame: read by png_camera and upload, before any frame()
        self.bounds = None  # their bounding box when the device found it (a flock drawn as points)

    def make_camera(self):
        """The window's first view: the whole 32^3 box from outside (``book_camera``: the book's, inside the flock;
        pictures frame the boids, ``png_camera``)."""
        return OrbitCamera(target=(0.0, 0.0, 0.0), distance=62.0, yaw=PICTURE_YAW, pitch=PICTURE_PITCH)

    def book_camera(self):
        return OrbitCamera(target=(0.0, 0.0, 0.0), distance=10.0)  # book: camera at (0, 0, -10), FOV 60

    def png_camera(self):
        """Pictures and videos: the boids framed from outside (``frame``); the book's camera sits inside the flock."""
        camera = PictureCamera(yaw=PICTURE_YAW, pitch=PICTURE_PITCH)
        self.positions, self.bounds = self.sim.boids()["position"][:, :3], None  # the state now, uploaded or not
        self.frame(camera)
        return camera

    def frame(self, camera: PictureCamera) -> None:
        """Frame the whole wall box, or close in on the boids where they all fit nearer than that (the book's start:
        N boids in a ball of radius 1, bursting out for the first seconds): every boid in the frame, the cage drawn
        where its corners are in it too. Only the boids' positions decide, so a video refitted each frame is steady."""
        p = self.sim.params
        half = np.asarray(p.wall_size, float) / 2
        corners = np.asarray(p.wall_center, float) + half * np.array(list(itertools.product((-1, 1), repeat=3)))
        camera.target = tuple(map(float, p.wall_center))
        camera.fit(corners)
        points = self.positions
        if self.bounds is not None or len(points) > FIT_POINTS:
            if self.bounds is not None:  # the device's (PackBoidsHalf)
                lo, hi = self.bounds
            else:  # column by column: numpy reduces a strided column in one tight loop, (N, 3) along axis 0 row by row
                lo, hi = (np.array([f(points[:, a]) for a in range(3)]) for f in (np.min, np.max))
            points = np.array([[(lo, hi)[k][a] for a, k in enumerate(c)] for c in itertools.product((0, 1), repeat=3)])
        centre = points.mean(axis=0)
        outward = points - centre
        outward /= np.maximum(np.linalg.norm(outward, axis=1, keepdims=True), 1e-6)
        reach = 0.5 * float(np.linalg.norm(p.object_scale))  # a boid's mesh reaches this far from its centre
        near = dataclasses.replace(camera, target=tuple(map(float, centre)))
        near.fit(points + reach * outward, CLOSE_UP_FILL)
        if near.distance >= camera.distance:
            camera.shows_cage = True
            return
        camera.target, camera.distance = near.target, near.distance
        clip = camera.projection() @ camera.view() @ np.column_stack([corners, np.ones(8)]).T
        camera.shows_cage = bool((clip[3] > 0).all() and (np.abs(clip[:2] / clip[3]) < CAGE_MARGIN).all())

    def upload(self) -> None:
        read = self.sim.runtime.read_back
        if self.sim.n > POINT_BOIDS:  # drawn a point each: half floats, half the bytes for GL
            device, self.bounds = self.sim.packed_boids()
            packed = read(device)
            if self.points.write(packed):
                self.point_vao = self.ctx.vertex_array(
                    self.point_program, [(self.points.buffer, "4f2 4f2", "in_offset", "in_velocity")]
                )
        else:
            data = read(self.sim.boid_data)
            self.positions, self.bounds = data["position"][:, :3], None
            if self.instances.write(data):
                self.vao = self.ctx.vertex_array(
                    self.program,
                    [
                        (self.mesh_vbo, "3f 3f", "in_position", "in_normal"),
                        (self.instances.buffer, "4f 4f/i", "in_velocity", "in_offset"),
                    ],
                    index_buffer=self.mesh_ibo,
                )
        p = self.sim.params
        self.box.set(box_edges(p.wall_center, p.wall_size))

    def draw(self, camera) -> None:
        p = self.sim.params
        if isinstance(camera, PictureCamera):  # a video's frames follow the boids
            self.frame(camera)
        self.ctx.enable(moderngl.DEPTH_TEST)
        points = self.sim.n > POINT_BOIDS
        program = self.point_program if points else self.program
        set_camera(program, camera)
        set_uniform(program, "object_scale", p.object_scale)
        set_uniform(program, "color_by_speed", self.color_by_speed)
        set_uniform(program, "max_speed", p.max_speed)
        if points:
            self.ctx.enable(moderngl.PROGRAM_POINT_SIZE)
            set_uniform(program, "pixels_per_unit", float(camera.projection()[1, 1] * self.ctx.viewport[3] / 2))
            self.point_vao.render(moderngl.POINTS, vertices=self.sim.n)
            self.ctx.disable(moderngl.PROGRAM_POINT_SIZE)
        else:
            self.vao.render(moderngl.TRIANGLES, instances=self.sim.n)
        if self.show_box and getattr(camera, "shows_cage", True):
            self.box.draw(camera)

    def status(self) -> list[str]:
        p = self.sim.params
        rules = [
            name
            for name, w in (("sep", p.separate_weight), ("ali", p.alignment_weight), ("coh", p.cohesion_weight))
            if w
        ]
        return [
            f"N = {self.sim.n}  ForceCS: {p.variant} ({self.sim.force_kernel()})  rules: {' '.join(rules) or 'none'}"
            f"  sep w = {p.separate_weight:g}"
        ]

    # {{{ key actions

    def fewer_boids(self) -> None:
        self.sim.update(max_object_num=max(MIN_BOIDS, (self.sim.n // 2) // 256 * 256))

    def more_boids(self) -> None:
        self.sim.update(max_object_num=min(MAX_BOIDS, max(MIN_BOIDS, self.sim.n * 2 // 256 * 256)))

    def more_separation(self) -> None:
        self.sim.update(separate_weight=self.sim.params.separate_weight + 0.5)

    def less_separation(self) -> None:
        self.sim.update(separate_weight=max(0.0, self.sim.params.separate_weight - 0.5))

    def _toggle_weight(self, name: str) -> None:
        current = getattr(self.sim.params, name)
        if current:
            self.saved_weights[name] = current
            self.sim.update(**{name: 0.0})
        else:
            self.sim.update(**{name: self.saved_weights.get(name, getattr(type(self.sim.params)(), name))})

    def toggle_separation(self) -> None:
        self._toggle_weight("separate_weight")

    def toggle_alignment(self) -> None:
        self._toggle_weight("alignment_weight")

    def toggle_cohesion(self) -> None:
        self._toggle_weight("cohesion_weight")

    def next_variant(self) -> None:
        variants = ("auto", "tiled", "lanes", "naive", "grid")
        self.sim.update(variant=variants[(variants.index(self.sim.params.variant) + 1) % len(variants)])

    def toggle_box(self) -> None:
        self.show_box = not self.show_box

    def toggle_colors(self) -> None:
        self.color_by_speed = not self.color_by_speed

    # }}}
