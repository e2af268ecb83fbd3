"""MultiPlane projection view (vol.1 ch.9, RoomProjection sample): one framebuffer per room face, the CG world
rendered into each with that face's off-axis camera, and the room's quads textured with them. ``c`` switches
between the eye's view (the frusta's apex: the faces join seamlessly) and an outside view of the room.

The faces are rasterised with GL here, as the book's cameras render its city, rather than uploaded from the OpenCL
ray-marcher: the projection matrices are then used the way the chapter is about (by a rasteriser, with their
depth rows, near and far planes), and the faces follow the eye at frame rate even where OpenCL runs on a CPU.
The world, its shading and the matrices are the scene module's, so both paths show the same picture.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import moderngl
import numpy as np

from ugpcl.geometry.multiplane_projection import (
    SHAPE_SPHERE,
    WORLD_FIELDS,
    camera_view,
    eye_camera,
    room_faces,
    world_record,
)
from ugpcl.scenes.multiplane_projection import MAX_DISTANCE

from ..camera import OrbitCamera, perspective
from ..gl import Lines, load_program, set_camera, set_uniform
from ..meshes import box_edges, cube, uv_sphere
from . import Key
from . import View as BaseView

SHADE_SKY, SHADE_SHAPE, SHADE_GROUND = 0, 1, 2
"""``shading`` of multiplane_projection_world.frag."""
TEXTURE_UNITS = {"face_image": 0}
EYE_STEP = 0.25
"""Metres the eye moves per arrow or bracket key."""
TURN_STEP = 15.0
"""Degrees the eye's view turns per j/l (i/k: 10 degrees up or down)."""
EYE_MARGIN = 0.2
"""The keys keep the eye this far (metres) inside every face."""
EYE_NEAR = 0.02
"""Near plane of the eye's camera in the room, metres (the eye may stand EYE_MARGIN from a wall)."""
MODES = ("outside", "eye")


@dataclass
class EyeCamera:
    """The viewer's own camera at the eye (the frusta's apex), in room metres: the sim's view_yaw/pitch/fov."""

    position: np.ndarray
    basis: np.ndarray
    """Rows R, U, F."""
    fov: float
    aspect: float = field(default=16 / 9)

    def eye(self) -> np.ndarray:
        return self.position

    def view(self) -> np.ndarray:
        return camera_view(self.basis, self.position)

    def projection(self) -> np.ndarray:
        return perspective(self.fov, self.aspect, EYE_NEAR, 1000.0)


class View(BaseView):
    title = "MultiPlane projection (vol.1 ch.9)"
    background = (0.08, 0.08, 0.1)
    keys = (
        Key("c", "camera: outside view of the room / the eye's view (seamless)", "next_mode"),
        Key("up", "eye forward (along the eye's heading)", "eye_forward"),
        Key("down", "eye back", "eye_back"),
        Key("left", "eye left", "eye_left"),
        Key("right", "eye right", "eye_right"),
        Key("]", "eye up", "eye_up"),
        Key("[", "eye down", "eye_down"),
        Key("j", "turn the eye's view left 15 degrees", "turn_left"),
        Key("l", "turn the eye's view right 15 degrees", "turn_right"),
        Key("i", "eye's view up 10 degrees", "look_up"),
        Key("k", "eye's view down 10 degrees", "look_down"),
        Key("6", "ceiling on/off (faces 5 / 6)", "toggle_ceiling"),
        Key("f", "frusta lines from the eye to every face's corners on/off", "toggle_frusta"),
        Key("0", "eye back to the start (room centre, 1.46 m above the floor)", "eye_home"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.world_program = load_program(ctx, "multiplane_projection_world")
        self.sky_program = load_program(
            ctx, "multiplane_projection_world", vertex="multiplane_projection_sky"
        )  # the same shading
        self.room_program = load_program(ctx, "multiplane_projection_room")
        self.sky_vao = ctx.vertex_array(self.sky_program, [])
        self.meshes = {}
        for kind, (vertices, indices) in (("sphere", uv_sphere(48, 24)), ("box", cube())):
            self.meshes[kind] = (ctx.buffer(vertices.tobytes()), ctx.buffer(indices.tobytes()))
        ground = np.array([[x, 0, z, 0, 1, 0] for x, z in ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5))], "f4")
        self.meshes["ground"] = (ctx.buffer(ground.tobytes()), ctx.buffer(np.array([0, 2, 1, 0, 3, 2], "i4")))
        self.frusta = Lines(ctx, color=(1.0, 0.85, 0.2, 1.0))
        self.outline = Lines(ctx, color=(0.6, 0.6, 0.6, 1.0))
        self.mode, self.show_frusta = "outside", True
        self.targets, self.target_key, self.rendered_key = None, None, None
        self.world_key, self.instances = None, {}

    def make_camera(self):
        # the sample's simulation camera: room-local (0, 8.98, -15.7) looking 18.84 degrees down at the room
        return OrbitCamera(target=(0.0, 2.0, 0.0), distance=18.0, yaw=-25.0, pitch=24.0, near=0.3, far=1000.0)

    # {{{ GL objects that follow the params

    def _ensure_targets(self) -> None:
        """One colour texture + depth buffer per face, of face_resolution."""
        p = self.sim.params
        key = (p.faces, p.face_resolution)
        if key == self.target_key:
            return
        for texture, fbo in self.targets or ():
            texture.release()
            fbo.release()
        self.targets = []
        for _ in range(p.faces):
            texture = self.ctx.texture(p.face_resolution, 4)
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            texture.repeat_x = texture.repeat_y = False  # clamp to the edge: no bleeding across the seams
            depth = self.ctx.depth_renderbuffer(p.face_resolution)
            self.targets.append((texture, self.ctx.framebuffer(color_attachments=[texture], depth_attachment=depth)))
        self.target_key = key

    def _ensure_world(self) -> None:
        """Instance buffers of the shapes (per kind: centre, scale, colour) and the ground quad."""
        p, shapes = self.sim.params, self.sim.shapes
        key = (id(shapes), p.ground_y, tuple(p.eye), p.world_scale)
        if key == self.world_key:
            return
        spheres = shapes["center"][:, 3] == SHAPE_SPHERE
        scale = np.where(spheres[:, None], shapes["size"][:, [0, 0, 0]], 2 * shapes["size"][:, :3])
        rows = np.concatenate([shapes["center"][:, :3], scale, shapes["color"][:, :3]], axis=1)
        eye = self.sim.eye_cg
        ground = np.array([[eye[0], p.ground_y, eye[2], 2 * MAX_DISTANCE, 1.0, 2 * MAX_DISTANCE, 0, 0, 0]])
        for kind, data in (("sphere", rows[spheres]), ("box", rows[~spheres]), ("ground", ground)):
            old = self.instances.pop(kind, None)
            if old is not None:
                old[0].release()
            if not len(data):
                continue
            buffer = self.ctx.buffer(np.ascontiguousarray(data, "f4").tobytes())
            vertices, indices = self.meshes[kind]
            vao = self.ctx.vertex_array(
                self.world_program,
                [
                    (vertices, "3f 3f", "in_position", "in_normal"),
                    (buffer, "3f 3f 3f/i", "in_center", "in_scale", "in_color"),
                ],
                index_buffer=indices,
            )
            self.instances[kind] = (buffer, vao, len(data))
        self.world_key = key

    def _room(self) -> None:
        """The room's quads (sim.mesh(), its atlas uvs turned back into each face's own [0, 1]^2)."""
        mesh = self.sim.mesh()
        faces = self.sim.params.faces
        face = np.repeat(np.arange(faces), 4)
        uvs = np.column_stack([mesh.uvs[:, 0] * faces - face, mesh.uvs[:, 1]])
        data = np.concatenate([mesh.vertices, mesh.normals, uvs], axis=1).astype("f4")
        self.room_buffer = self.ctx.buffer(data.tobytes())
        self.room_index = self.ctx.buffer(mesh.faces.astype("i4").tobytes())
        self.room_vao = self.ctx.vertex_array(
            self.room_program,
            [(self.room_buffer, "3f 3f 2f", "in_position", "in_normal", "in_uv")],
            index_buffer=self.room_index,
        )

    # }}}

    def upload(self) -> None:
        """Render every face image (only when the eye, the world or the faces changed)."""
        p = self.sim.params
        if self.rendered_key == p:
            return
        self._ensure_targets()
        self._ensure_world()
        self._room()
        ctx, target, viewport = self.ctx, self.ctx.fbo, self.ctx.viewport
        world = world_record(p.ground_y)[0]
        for program in (self.world_program, self.sky_program):
            for name in WORLD_FIELDS:
                set_uniform(program, name, tuple(float(v) for v in world[name][:3]))
            set_uniform(program, "eye", tuple(float(v) for v in self.sim.eye_cg))
        cameras = self.sim.cameras
        for k, (_, fbo) in enumerate(self.targets):
            fbo.use()
            ctx.viewport = (0, 0, *p.face_resolution)
            ctx.clear(depth=1.0)
            ctx.enable(moderngl.DEPTH_TEST)
            set_uniform(self.world_program, "m_proj", cameras.proj[k])
            set_uniform(self.world_program, "m_view", cameras.view[k])
            for kind, (_, vao, count) in self.instances.items():
                set_uniform(self.world_program, "shading", SHADE_GROUND if kind == "ground" else SHADE_SHAPE)
                vao.render(moderngl.TRIANGLES, instances=count)
            # the sky last, at depth 1: it fills only the pixels nothing was drawn on
            ctx.depth_func = "<="
            set_uniform(self.sky_program, "m_inverse", np.linalg.inv(cameras.proj[k] @ cameras.view[k]))
            set_uniform(self.sky_program, "shading", SHADE_SKY)
            self.sky_vao.render(moderngl.TRIANGLES, vertices=3)
            ctx.depth_func = "<"
        if target is not None:  # a fresh offscreen context has bound nothing yet; its frame binds itself next
            target.use()
            ctx.viewport = viewport
        self.rendered_key = p
        self._lines()

    def _lines(self) -> None:
        p = self.sim.params
        basis, size, center = room_faces(p.room_size)
        pivot = np.array([0.0, p.room_size[1] / 2, 0.0])
        segments = []
        for k in range(p.faces):
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                corner = pivot + center[k] + basis[k, 0] * a * size[k, 0] / 2 + basis[k, 1] * b * size[k, 1] / 2
                segments += [p.eye, corner]
        self.frusta.set(np.array(segments))
        self.outline.set(box_edges(pivot, p.room_size))

    def eye_camera(self, aspect: float) -> EyeCamera:
        """The camera at the eye with the sim's view heading, pitch and FOV."""
        p = self.sim.params
        basis, _ = eye_camera(p.view_yaw, p.view_pitch, p.view_fov, aspect)
        return EyeCamera(np.asarray(p.eye, float), basis, p.view_fov, aspect)

    def draw(self, camera) -> None:
        if self.mode == "eye":
            camera = self.eye_camera(camera.aspect)
        ctx = self.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        set_camera(self.room_program, camera)
        self.room_program["face_image"].value = TEXTURE_UNITS["face_image"]
        for k, (texture, _) in enumerate(self.targets):
            texture.use(TEXTURE_UNITS["face_image"])
            self.room_vao.render(moderngl.TRIANGLES, vertices=6, first=6 * k)
        if self.mode == "outside":
            self.outline.draw(camera)
            if self.show_frusta:
                self.frusta.draw(camera)

    def status(self) -> list[str]:
        p, c = self.sim.params, self.sim.cameras
        eye = ", ".join(f"{v:.2f}" for v in p.eye)
        lines = [f"{self.mode} view   eye ({eye}) m   faces {p.faces}   face images {p.face_resolution}"]
        for k, name in enumerate(c.names):
            lines.append(
                f"{name:6s} d {c.distance[k]:6.3f}  vFOV {c.vfov_deg[k]:7.3f}  shift ({c.shift[k, 0]:+.3f}, "
                f"{c.shift[k, 1]:+.3f})"
            )
        return lines

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        if self.mode == "eye":  # look around from the eye
            p = self.sim.params
            yaw = (p.view_yaw + du * 180.0 + 180.0) % 360.0 - 180.0
            self.sim.update(view_yaw=yaw, view_pitch=float(np.clip(p.view_pitch + dv * 90.0, -89.0, 89.0)))
        else:
            camera.drag(du * 600, dv * 600)

    # {{{ key actions

    def next_mode(self) -> None:
        self.mode = MODES[(MODES.index(self.mode) + 1) % len(MODES)]

    def _move_eye(self, forward: float, right: float, up: float) -> None:
        p = self.sim.params
        yaw = math.radians(p.view_yaw)
        step = (
            np.array([math.sin(yaw), 0.0, math.cos(yaw)]) * forward
            + np.array([math.cos(yaw), 0.0, -math.sin(yaw)]) * right
        )
        half = np.asarray(p.room_size) / 2 - EYE_MARGIN
        lower, upper = (
            np.array([-half[0], EYE_MARGIN, -half[2]]),
            np.array([half[0], p.room_size[1] - EYE_MARGIN, half[2]]),
        )
        eye = np.clip(np.asarray(p.eye) + step + (0.0, up, 0.0), lower, upper)
        self.sim.update(eye=tuple(float(v) for v in eye))

    def eye_forward(self) -> None:
        self._move_eye(EYE_STEP, 0.0, 0.0)

    def eye_back(self) -> None:
        self._move_eye(-EYE_STEP, 0.0, 0.0)

    def eye_left(self) -> None:
        self._move_eye(0.0, -EYE_STEP, 0.0)

    def eye_right(self) -> None:
        self._move_eye(0.0, EYE_STEP, 0.0)

    def eye_up(self) -> None:
        self._move_eye(0.0, 0.0, EYE_STEP)

    def eye_down(self) -> None:
        self._move_eye(0.0, 0.0, -EYE_STEP)

    def turn_left(self) -> None:
        self.sim.update(view_yaw=(self.sim.params.view_yaw - TURN_STEP + 180.0) % 360.0 - 180.0)

    def turn_right(self) -> None:
        self.sim.update(view_yaw=(self.sim.params.view_yaw + TURN_STEP + 180.0) % 360.0 - 180.0)

    def look_up(self) -> None:
        self.sim.update(view_pitch=min(89.0, self.sim.params.view_pitch + 10.0))

    def look_down(self) -> None:
        self.sim.update(view_pitch=max(-89.0, self.sim.params.view_pitch - 10.0))

    def toggle_ceiling(self) -> None:
        self.sim.update(faces=11 - self.sim.params.faces)

    def toggle_frusta(self) -> None:
        self.show_frusta = not self.show_frusta

    def eye_home(self) -> None:
        self.sim.update(eye=type(self.sim.params)().eye)

    # }}}
