"""MultiPlane perspective projection: a room whose walls and floor show one CG world seamlessly, from a tracked eye
(vol.1 ch.9; docs/chapters/09-multiplane-projection.md).

Each face of the room (4 walls and the floor, the book's room; ``faces=6`` adds the ceiling) gets a camera at the
eye whose frustum has exactly that face as its base: vertical FOV = 2 atan2(H/2, d), aspect = W/H (Listing 9.1)
and the eye's offset from the face centre as a lens shift in entries [0,2], [1,2] of the projection matrix
(Listing 9.2). The frusta share their apex and touch along the room's edges, so from the eye the images join into
one picture. All geometry is in Unity's (left-handed, y up) coordinates; the host math here is the one source of
the matrices (the viewer draws with them, the kernels get their entries).

Per step (the book's CameraGenerator.Update): recompute every face camera from scratch (``face_cameras``); the
face images are made when asked for: ``RenderFaces`` (the world ray-marched through every face camera), then for
the eye's own picture ``RenderEyeDirect`` (the ideal view) and ``CompositeEyeView`` (the room as the viewer sees it).
The interactive viewer renders the faces with GL instead (viewer/views/multiplane_projection.py).

Differences from the book: the CG world is a small analytic one (ground, boxes, spheres; the book's is a
third-party city); the eye is measured from the room's centre when the matrices are made (the original measures it
from the floor pivot, which moves the windows 2.5 m down; docs page, "What differs"); the ceiling is optional.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyopencl.cltypes as cltypes

from ..bench.timing import seconds_per_call
from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..geometry.transforms import euler_matrix, perspective
from ..scene import Animation, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

FACE_NAMES = ("Front", "Right", "Back", "Left", "Bottom", "Top")
"""The book's face order (Room.cs: Front, Right, Back, Left, Bottom), then the ceiling of ``faces=6``."""
FACE_EULER = ((0, 0, 0), (0, 90, 0), (0, 180, 0), (0, 270, 0), (90, 0, 0), (-90, 0, 0))
"""Unity Euler angles (degrees) of each face's camera: it looks from the room centre at the face."""
NEAR_CLIP_PLANE = 0.3
"""Near plane of the face cameras (Unity's default camera), CG units."""
FAR_PER_DISTANCE = 1000.0
"""Far plane = this times the eye-to-face distance (book: farClipPlane = distance * 1000)."""
MIN_WALL_DISTANCE = 0.05
"""The eye stays this far (metres) inside every face: at d -> 0 the FOV -> 180 degrees and the frustum degenerates."""

MARCH_STEPS = 128
"""Sphere-tracing steps per ray before it is taken as a miss (build define of multiplane_projection.cl)."""
SURFACE_EPSILON = 0.01
"""A ray hits a shape closer than this, CG units (build define)."""
MAX_DISTANCE = 10000.0
"""Rays end here and show the sky, CG units (build define)."""

SHAPE_DTYPE = np.dtype([("center", "<f4", 4), ("size", "<f4", 4), ("color", "<f4", 4)])
"""Mirror of ``Shape`` in multiplane_projection.cl: center.w = SHAPE_SPHERE (0) or SHAPE_BOX (1)."""
SHAPE_SPHERE, SHAPE_BOX = 0.0, 1.0
WORLD_FIELDS = (
    "sun_direction",
    "sun_color",
    "ambient",
    "sky_horizon",
    "sky_zenith",
    "ground_dark",
    "ground_light",
    "ground",
)
WORLD_DTYPE = np.dtype([(name, "<f4", 4) for name in WORLD_FIELDS])
"""Mirror of ``World`` in multiplane_projection.cl; the viewer's GLSL gets the same values as uniforms."""
SUN_DIRECTION = (-0.321, -0.766, 0.557)
"""Direction the sunlight travels: the suite's Unity default light (viewer/shaders/include/lighting.glsl)."""
SUN_COLOR = (1.0, 0.957, 0.839)
AMBIENT = (0.212, 0.227, 0.259)
SKY_HORIZON = (0.75, 0.82, 0.90)
SKY_ZENITH = (0.25, 0.45, 0.80)
GROUND_DARK = (0.30, 0.32, 0.28)
GROUND_LIGHT = (0.62, 0.64, 0.58)
CHECKER_SIZE = 40.0
"""Side of the ground's checker squares, CG units."""
FOG_DISTANCE = 1500.0
"""Distance at which the fog has covered 1 - 1/e of a colour, CG units."""


@dataclass(frozen=True)
class Params(BaseParams):
    room_size: tuple[float, float, float] = param((20.0, 5.0, 10.0), 0.5, 1000.0)
    """Room width (x), height (y) and depth (z), metres (book: Room._size)."""
    eye: tuple[float, float, float] = param((0.0, 1.46, 0.0), -1000.0, 1000.0, live=True)
    """Eye position, metres from the floor centre (the room's pivot), Unity axes, inside the room (book: the tracked
    viewpoint; the sample's character eye, 1.46 m above the floor)."""
    faces: int = param(5, choices=(5, 6))
    """Projection faces: 5 = four walls and the floor (the book's room), 6 adds the ceiling (section 9.2)."""
    face_resolution: tuple[int, int] = param((1024, 512), 1, 8192)
    """Pixels of every face image, width x height (book: _texSize of the sample scene)."""
    world_scale: float = param(20.0, 0.0, 10000.0, lo_open=True, live=True)
    """CG world units per room metre: the eye in the CG world is eye x world_scale (book: _eyePointToWorldScale)."""
    ground_y: float = param(-100.0, -100000.0, 100000.0, live=True)
    """Height of the CG world's ground plane, CG units (the sample places its city at y = -100)."""
    shape_count: int = param(24, 0, 1024)
    """Boxes and spheres of the CG world, placed from the seed around the room."""
    view_yaw: float = param(30.0, -360.0, 360.0, live=True)
    """Heading of the eye's own view, degrees about +y (0 looks along +z, at the front wall)."""
    view_pitch: float = param(-10.0, -89.0, 89.0, live=True)
    """Elevation of the eye's own view, degrees above the horizon."""
    view_fov: float = param(90.0, 1.0, 179.0, live=True)
    """Vertical field of view of the eye's own view, degrees (the sample's first-person camera: 60)."""
    view_resolution: tuple[int, int] = param((256, 256), 1, 8192)
    """Pixels of the eye's direct and composite views, width x height."""

    limits = (f"distance from eye to every face of room_size >= {MIN_WALL_DISTANCE} m",)

    def check(self) -> None:
        (x, y, z), (width, height, depth) = self.eye, self.room_size
        margin = min(width / 2 - abs(x), y, height - y, depth / 2 - abs(z))  # the floor distance is y itself, exactly
        if margin < MIN_WALL_DISTANCE:
            raise self.broken(self.limits[0], f"{margin:g} m")


# {{{ host math: the room and its off-axis cameras (the single source of the matrices)


def face_basis() -> np.ndarray:
    """(6, 3, 3): rows R, U, F of each face camera: forward F and up U rotated by FACE_EULER, right R = U x F
    (the camera's right in Unity's left-handed world, as the plain cross product of its numbers)."""
    basis = np.zeros((6, 3, 3))
    for k, angles in enumerate(FACE_EULER):
        rotation = euler_matrix(*angles)[:3, :3]
        forward, up = rotation @ (0.0, 0.0, 1.0), rotation @ (0.0, 1.0, 0.0)
        basis[k] = np.rint([np.cross(up, forward), up, forward])  # exact axes: the angles are multiples of 90
    return basis


def room_faces(room_size) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(basis (6,3,3), size (6,2) = (W along R, H along U), centre (6,3) relative to the room centre)."""
    basis = face_basis()
    size3 = np.asarray(room_size, float)
    size = np.stack([np.abs(basis[:, 0]) @ size3, np.abs(basis[:, 1]) @ size3], axis=1)
    center = basis[:, 2] * (np.abs(basis[:, 2]) @ size3 / 2)[:, None]
    return basis, size, center


def frustum(left: float, right: float, bottom: float, top: float, near: float, far: float) -> np.ndarray:
    """glFrustum: the OpenGL projection of the view-space window [left, right] x [bottom, top] on the near plane
    (camera looking down -z, C_w = -V_z, NDC z in [-1, 1]; section 9.3)."""
    return np.array(
        [
            [2 * near / (right - left), 0, (right + left) / (right - left), 0],
            [0, 2 * near / (top - bottom), (top + bottom) / (top - bottom), 0],
            [0, 0, -(far + near) / (far - near), -2 * far * near / (far - near)],
            [0, 0, -1, 0],
        ]
    )


def lens_shift_projection(fov_degrees: float, aspect: float, shift, near: float, far: float) -> np.ndarray:
    """The book's way: a symmetric perspective from FOV and aspect (Listing 9.1) with the lens shift written into
    entries [0,2] and [1,2] (Listing 9.2). Equal to ``frustum`` of the shifted window."""
    projection = perspective(fov_degrees, aspect, near, far)
    projection[0, 2], projection[1, 2] = shift
    return projection


@dataclass(frozen=True)
class FaceCameras:
    """The cameras of the room's faces for one eye position (arrays over the ``faces`` faces)."""

    names: tuple[str, ...]
    basis: np.ndarray
    """(faces, 3, 3) rows R, U, F."""
    size: np.ndarray
    """(faces, 2) face width and height, metres."""
    center: np.ndarray
    """(faces, 3) face centres relative to the room centre, metres."""
    distance: np.ndarray
    """(faces,) eye-to-plane distance d, metres (book: faceDistance + positionOffset.z)."""
    offset: np.ndarray
    """(faces, 2) (cx, cy): the face centre seen from the eye along the camera's R and U, metres."""
    eye_cg: np.ndarray
    """(3,) where the cameras stand in the CG world."""
    near: float = NEAR_CLIP_PLANE

    @property
    def proj(self) -> np.ndarray:
        """(faces, 4, 4) projection matrices from each face's window (OpenGL convention, row-major)."""
        return np.stack([frustum(*self.bounds(k)) for k in range(len(self.names))])

    @property
    def view(self) -> np.ndarray:
        """(faces, 4, 4) CG-world view matrices: rows (R, U, -F) applied to (p - eye_cg)."""
        return np.stack([camera_view(b, self.eye_cg) for b in self.basis])

    @property
    def vfov_deg(self) -> np.ndarray:
        """Vertical FOV = 2 atan2(H/2, d) (Listing 9.1)."""
        return np.degrees(2 * np.arctan2(self.size[:, 1] / 2, self.distance))

    @property
    def aspect(self) -> np.ndarray:
        return self.size[:, 0] / self.size[:, 1]

    @property
    def shift(self) -> np.ndarray:
        """Lens shift in NDC units, 2 (cx, cy) / (W, H) = entries [0,2], [1,2] (Listing 9.2)."""
        return 2 * self.offset / self.size

    @property
    def far(self) -> np.ndarray:
        return FAR_PER_DISTANCE * self.distance

    def bounds(self, k: int) -> tuple[float, float, float, float, float, float]:
        """(l, r, b, t, n, f) of face k: its window scaled onto the near plane."""
        n, d, (cx, cy), (w, h) = self.near, self.distance[k], self.offset[k], self.size[k]
        return n * (cx - w / 2) / d, n * (cx + w / 2) / d, n * (cy - h / 2) / d, n * (cy + h / 2) / d, n, self.far[k]

    def lens(self) -> np.ndarray:
        """(faces, 4) float32 (P00, P02, P11, P12) for the kernels."""
        return self.proj[:, [0, 0, 1, 1], [0, 2, 1, 2]].astype(np.float32)


def face_cameras(room_size, eye_center, faces: int, eye_cg=(0.0, 0.0, 0.0), near: float = NEAR_CLIP_PLANE):
    """Every face camera for the eye at ``eye_center`` (metres from the room centre), made from scratch as Unity's
    ResetProjectionMatrix does. The CG-world cameras stand at ``eye_cg`` with the same orientations."""
    basis, size, center = (a[:faces] for a in room_faces(room_size))
    v = center - np.asarray(eye_center, float)  # eye -> face centre
    distance = np.einsum("kj,kj->k", v, basis[:, 2])
    if (distance <= 0).any():
        raise ValueError(f"the eye {tuple(eye_center)} is not inside the room: it must be in front of every face")
    offset = np.stack([np.einsum("kj,kj->k", v, basis[:, 0]), np.einsum("kj,kj->k", v, basis[:, 1])], axis=1)
    return FaceCameras(FACE_NAMES[:faces], basis, size, center, distance, offset, np.asarray(eye_cg, float), near)


def camera_view(basis: np.ndarray, position) -> np.ndarray:
    """View matrix of a camera with rows R, U, F at ``position``: rows (R, U, -F), so it looks down -z."""
    rotation = np.array([basis[0], basis[1], -basis[2]])
    view = np.identity(4)
    view[:3, :3] = rotation
    view[:3, 3] = -rotation @ np.asarray(position, float)
    return view


def eye_camera(yaw: float, pitch: float, fov: float, aspect: float) -> tuple[np.ndarray, np.ndarray]:
    """(basis (3,3) rows R, U, F; lens (P00, P02, P11, P12)) of the eye's own pinhole camera."""
    rotation = euler_matrix(-pitch, yaw)[:3, :3]  # Unity's Euler x turns the view down
    forward, up = rotation @ (0.0, 0.0, 1.0), rotation @ (0.0, 1.0, 0.0)
    focal = 1.0 / math.tan(math.radians(fov) / 2)
    return np.array([np.cross(up, forward), up, forward]), np.array([focal / aspect, 0.0, focal, 0.0])


# }}}

# {{{ the CG world


def world_shapes(count: int, seed: int, ground_y: float) -> np.ndarray:
    """``count`` shapes of SHAPE_DTYPE around the origin: boxes standing on the ground at 250..700 units in every
    direction (buildings), spheres among them, and every fourth shape a box floating overhead (for the ceiling)."""
    rng = np.random.default_rng(seed)
    shapes = np.zeros(count, SHAPE_DTYPE)
    for i in range(count):
        angle, radius = rng.uniform(0, 2 * math.pi), rng.uniform(250.0, 700.0)
        x, z = radius * math.cos(angle), radius * math.sin(angle)
        color = rng.uniform(0.25, 0.95, 3)
        if i % 4 == 3:  # floating box above the room
            half = rng.uniform(20.0, 60.0, 3)
            shapes[i] = ((x * 0.4, rng.uniform(250.0, 450.0), z * 0.4, SHAPE_BOX), (*half, 0), (*color, 1))
        elif i % 4 == 1:
            r = rng.uniform(20.0, 60.0)
            shapes[i] = ((x, ground_y + r, z, SHAPE_SPHERE), (r, r, r, 0), (*color, 1))
        else:
            half = (rng.uniform(15.0, 50.0), rng.uniform(20.0, 160.0), rng.uniform(15.0, 50.0))
            shapes[i] = ((x, ground_y + half[1], z, SHAPE_BOX), (*half, 0), (*color, 1))
    return shapes


def world_record(ground_y: float) -> np.ndarray:
    """The World record (lights, sky, ground) as one WORLD_DTYPE element."""
    world = np.zeros(1, WORLD_DTYPE)
    direction = np.asarray(SUN_DIRECTION) / np.linalg.norm(SUN_DIRECTION)
    values = (direction, SUN_COLOR, AMBIENT, SKY_HORIZON, SKY_ZENITH, GROUND_DARK, GROUND_LIGHT)
    for name, value in zip(WORLD_FIELDS, values, strict=False):
        world[name][0, :3] = value
    world["ground"][0, :3] = (ground_y, CHECKER_SIZE, FOG_DISTANCE)
    return world


# }}}


class Simulation(BaseSimulation):
    """The room's face cameras for the current eye; face images and eye views rendered on demand."""

    Params = Params

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program(
            "multiplane_projection",
            MARCH_STEPS=MARCH_STEPS,
            SURFACE_EPSILON=SURFACE_EPSILON,
            MAX_DISTANCE=MAX_DISTANCE,
        )
        self.shapes = world_shapes(p.shape_count, self.seed, p.ground_y)
        self.shape_buffer = rt.to_device(self.shapes if len(self.shapes) else np.zeros(1, SHAPE_DTYPE))
        width, height = p.face_resolution
        self.face_buffer = rt.empty((p.faces, height, width, 4), np.uint8)
        view_width, view_height = p.view_resolution
        self.direct_buffer = rt.empty((view_height, view_width, 4), np.uint8)
        self.composite_buffer = rt.empty((view_height, view_width, 4), np.uint8)
        self._uploaded = None  # the params the device copies of the world and cameras were made for
        self.camera_generator_update()

    # {{{ per frame: the book's CameraGenerator.Update, then the kernels

    @property
    def eye_center(self) -> np.ndarray:
        """The eye relative to the room centre, metres (the frame the face matrices are made in)."""
        return np.asarray(self.params.eye) - (0.0, self.params.room_size[1] / 2, 0.0)

    @property
    def eye_cg(self) -> np.ndarray:
        """The eye in the CG world: eye x world_scale (the rig is the room pivot scaled up)."""
        return np.asarray(self.params.eye) * self.params.world_scale

    def camera_generator_update(self) -> None:
        """Every face camera from scratch for the current eye (book: CameraGenerator.Update)."""
        p = self.params
        self.cameras = face_cameras(p.room_size, self.eye_center, p.faces, self.eye_cg)

    def eye_view_camera(self) -> tuple[np.ndarray, np.ndarray]:
        """(basis, lens) of the eye's own camera (view_yaw, view_pitch, view_fov, view_resolution)."""
        p = self.params
        return eye_camera(p.view_yaw, p.view_pitch, p.view_fov, p.view_resolution[0] / p.view_resolution[1])

    def _device_inputs(self) -> dict:
        """Kernel inputs that follow the (live) params: uploaded again only when those changed."""
        p = self.params
        if self._uploaded != p:
            rt = self.runtime
            basis, lens = self.eye_view_camera()
            room_basis, room_size, room_center = room_faces(p.room_size)
            self._inputs = {
                "world": rt.to_device(world_record(p.ground_y)),
                "face_basis": rt.to_device(self.cameras.basis.astype(np.float32).ravel()),
                "face_lens": rt.to_device(self.cameras.lens()),
                "eye_basis": rt.to_device(basis.astype(np.float32).ravel()),
                "eye_lens": cltypes.make_float4(*lens),
                "room_basis": rt.to_device(room_basis.astype(np.float32).ravel()),
                "room_center": rt.to_device(room_center.astype(np.float32).ravel()),
                "room_size": rt.to_device(room_size.astype(np.float32).ravel()),
            }
            self._uploaded = p
        return self._inputs

    def render_faces(self) -> None:
        """RenderFaces: every face image, the world seen through that face's camera at the eye."""
        inputs, (width, height) = self._device_inputs(), self.params.face_resolution
        self.program.kernel("RenderFaces")(
            (width, height, self.params.faces),
            None,
            self.face_buffer,
            self.shape_buffer,
            np.int32(len(self.shapes)),
            inputs["world"],
            inputs["face_basis"],
            inputs["face_lens"],
            cltypes.make_float4(*self.eye_cg, 0.0),
            np.int32(width),
            np.int32(height),
        )

    def render_eye_direct(self) -> None:
        """RenderEyeDirect: the world seen straight from the eye (what the room should look like)."""
        inputs, (width, height) = self._device_inputs(), self.params.view_resolution
        self.program.kernel("RenderEyeDirect")(
            (width, height),
            None,
            self.direct_buffer,
            self.shape_buffer,
            np.int32(len(self.shapes)),
            inputs["world"],
            inputs["eye_basis"],
            inputs["eye_lens"],
            cltypes.make_float4(*self.eye_cg, 0.0),
            np.int32(width),
            np.int32(height),
        )

    def composite_eye_view(self) -> None:
        """CompositeEyeView: the eye looking at the room's faces showing the images of ``render_faces``."""
        inputs, (width, height) = self._device_inputs(), self.params.view_resolution
        face_width, face_height = self.params.face_resolution
        self.program.kernel("CompositeEyeView")(
            (width, height),
            None,
            self.composite_buffer,
            self.face_buffer,
            np.int32(self.params.faces),
            np.int32(face_width),
            np.int32(face_height),
            inputs["room_basis"],
            inputs["room_center"],
            inputs["room_size"],
            cltypes.make_float4(*self.eye_center, 0.0),
            inputs["eye_basis"],
            inputs["eye_lens"],
            np.int32(width),
            np.int32(height),
        )

    # }}}

    def _step(self, dt: float) -> None:
        self.camera_generator_update()  # the images follow on demand: a headless run only needs the last ones

    def update(self, **changes) -> None:
        super().update(**changes)
        self.camera_generator_update()  # a moved eye takes effect at once, not only at the next step

    def state(self) -> dict[str, np.ndarray]:
        self.render_faces()
        self.render_eye_direct()
        self.composite_eye_view()
        c = self.cameras
        return {
            "face_names": np.array(c.names),
            "face_images": self.face_buffer.get(),
            "proj": c.proj.astype(np.float32),
            "view": c.view.astype(np.float32),
            "distance": c.distance.astype(np.float32),
            "vfov_deg": c.vfov_deg.astype(np.float32),
            "aspect": c.aspect.astype(np.float32),
            "shift": c.shift.astype(np.float32),
            "eye": np.asarray(self.params.eye, np.float32),
            "eye_center": self.eye_center.astype(np.float32),
            "eye_cg": self.eye_cg.astype(np.float32),
            "direct_view": self.direct_buffer.get(),
            "composite_view": self.composite_buffer.get(),
        }

    def stats(self) -> dict:
        c = self.cameras
        return {
            **super().stats(),
            "faces": self.params.faces,
            "eye (m from the room centre)": tuple(round(float(v), 3) for v in self.eye_center),
            **{f"{name} d / vFOV / shift": _face_line(c, k) for k, name in enumerate(c.names)},
        }

    # {{{ geometry

    def mesh(self) -> Mesh:
        """The room's faces as quads (normals into the room, the side that shows the images), metres from the floor
        centre. uv addresses an atlas of the face images side by side (the texture): face k covers u in
        [k, k+1] / faces."""
        p = self.params
        basis, size, center = (a[: p.faces] for a in room_faces(p.room_size))
        corners = ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5))  # (u, v) - 0.5, counter-clockwise
        parts = []
        for k in range(p.faces):
            right, up, forward = basis[k]
            origin = center[k] + (0.0, p.room_size[1] / 2, 0.0)
            vertices = [origin + a * size[k, 0] * right + b * size[k, 1] * up for a, b in corners]
            uvs = [((k + a + 0.5) / p.faces, b + 0.5) for a, b in corners]
            # the image faces -F (into the room); (R, U) is counter-clockwise about -F when R x U = -F
            order = [0, 1, 2, 0, 2, 3] if np.dot(np.cross(right, up), -forward) > 0 else [0, 2, 1, 0, 3, 2]
            parts.append(Mesh(vertices, np.reshape(order, (2, 3)), np.tile(-forward, (4, 1)), uvs))
        room = Mesh.merge(parts)
        self.render_faces()
        atlas = np.concatenate(list(self.face_buffer.get()[: p.faces]), axis=1)  # (H, faces * W, 4), row 0 bottom
        # the texture in image-file order (top row first): a .glb shows the walls with their pictures
        return Mesh(room.vertices, room.faces, room.normals, room.uvs, texture=atlas[::-1])

    def export_mesh(self, path) -> None:
        write_mesh(path, self.mesh())

    # }}}


def _face_line(cameras: FaceCameras, k: int) -> str:
    shift = cameras.shift[k]
    return f"{cameras.distance[k]:.3f} m / {cameras.vfov_deg[k]:.3f} deg / ({shift[0]:+.3f}, {shift[1]:+.3f})"


MARCH_STEP_FLOPS = 7
"""One sphere-tracing step of trace() besides its shapes: p = origin + t dir (6) and t += nearest (1). Flop
convention of the benches: an FMA is 2, sqrt and a division 1 each, compares, min and max 0."""

SHAPE_DISTANCE_FLOPS = {SHAPE_SPHERE: 10, SHAPE_BOX: 13}
"""shape_distance() per shape and step: q = p - centre (3), length (dot 5, sqrt 1), then a sphere's - radius (1);
a box's |q| - half extents (3), length of the positive part (6) and the sum (1). The per-pixel direction, hit
shading and fog (about 60) are left out: the march's shapes x steps dominate."""


def march_steps(sim, samples: int = 16384) -> float:
    """Mean sphere-tracing steps per face pixel of RenderFaces: trace()'s march loop replayed in numpy (float64) on
    every stride-th pixel of each face, about ``samples`` of them (at least every 4th; the kernel keeps no count, and
    rounding may end a ray one step apart)."""
    p = sim.params
    width, height = p.face_resolution
    stride = max(4, math.ceil(math.sqrt(width * height / samples)))
    lens, basis, origin = sim.cameras.lens().astype(np.float64), sim.cameras.basis, np.asarray(sim.eye_cg, float)
    centres, sizes = sim.shapes["center"].astype(np.float64), sim.shapes["size"].astype(np.float64)
    sphere = centres[:, 3] == SHAPE_SPHERE
    i, j = np.meshgrid(np.arange(0, width, stride), np.arange(0, height, stride), indexing="xy")
    x, y = 2.0 * (i.ravel() + 0.5) / width - 1.0, 2.0 * (j.ravel() + 0.5) / height - 1.0
    counts = []
    for k in range(p.faces):
        right, up, forward = np.asarray(basis[k], np.float64).reshape(3, 3)
        vx, vy = (x + lens[k, 1]) / lens[k, 0], (y + lens[k, 3]) / lens[k, 2]
        d = vx[:, None] * right + vy[:, None] * up + forward
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        down = (d[:, 1] < 0.0) & (origin[1] > p.ground_y)
        t_ground = np.where(down, (p.ground_y - origin[1]) / np.where(down, d[:, 1], -1.0), np.inf)
        t_limit, t = np.minimum(t_ground, MAX_DISTANCE), np.zeros(len(d))
        steps, going = np.zeros(len(d), int), np.ones(len(d), bool)
        for _ in range(MARCH_STEPS):
            going &= t < t_limit
            if not going.any():
                break
            q = origin + t[going, None] * d[going]
            rel = q[:, None, :] - centres[None, :, :3]
            box = np.linalg.norm(np.maximum(np.abs(rel) - sizes[None, :, :3], 0.0), axis=2) + np.minimum(
                (np.abs(rel) - sizes[None, :, :3]).max(axis=2), 0.0
            )
            nearest = np.where(sphere, np.linalg.norm(rel, axis=2) - sizes[None, :, 0], box).min(axis=1, initial=np.inf)
            steps[going] += 1
            hit = nearest < SURFACE_EPSILON
            t[going] += np.where(hit, 0.0, nearest)
            going[np.nonzero(going)[0][hit]] = False
        counts.append(steps)
    return float(np.concatenate(counts).mean())


def bench(runtime, sizes=None) -> list[dict]:
    """ms per frame of RenderFaces (the 5 face images of the book's room) at face resolutions W x W/2, and the
    ray-marched pixels per second; march flop/s = (MARCH_STEP_FLOPS + SHAPE_DISTANCE_FLOPS of every shape) per
    march step x march_steps per pixel x pixels per second."""
    sizes = sizes or ([1024, 2048, 4096] if runtime.is_gpu else [128, 256])
    rows = []
    for width in sizes:
        height = max(1, width // 2)
        sim = Simulation(runtime, Params(face_resolution=(width, height), view_resolution=(16, 16)), seed=0)
        seconds = seconds_per_call(sim.render_faces, runtime.queue, max_calls=50)
        pixels = sim.params.faces * width * height
        step_flops = MARCH_STEP_FLOPS + sum(SHAPE_DISTANCE_FLOPS[float(w)] for w in sim.shapes["center"][:, 3])
        flops = step_flops * march_steps(sim) * pixels
        rows.append(
            {
                "face": f"{width}x{height}",
                "ms/frame": seconds * 1e3,
                "Mpixel/s": pixels / seconds / 1e6,
                "march flop/s": flops / seconds,
            }
        )
    return rows


SCENES = [
    Scene(
        "multiplane_projection",
        Simulation,
        "Room projection: 5 (or 6) off-axis face cameras from one eye, seamless from the eye (vol.1 ch.9)",
        preview={"steps": 1},
        animation=Animation(
            "the room and its projected walls do not change with time, so the camera swings round the room", swing=30.0
        ),
    )
]
