"""The host maths of the MultiPlane projection room (vol.1 ch.9; docs/chapters/09-multiplane-projection.md): the
room's faces, their off-axis cameras from a tracked eye (Listings 9.1, 9.2, glFrustum of section 9.3), the eye's own
pinhole camera, and the small analytic CG world the kernels and the viewer draw (its shapes and its World record).

The single source of the matrices: the scene passes their entries to the kernels, the viewer draws with them. All in
Unity's (left-handed, y up) coordinates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .transforms import euler_matrix, perspective

FACE_NAMES = ("Front", "Right", "Back", "Left", "Bottom", "Top")
"""The book's face order (Room.cs: Front, Right, Back, Left, Bottom), then the ceiling of ``faces=6``."""
FACE_EULER = ((0, 0, 0), (0, 90, 0), (0, 180, 0), (0, 270, 0), (90, 0, 0), (-90, 0, 0))
"""Unity Euler angles (degrees) of each face's camera: it looks from the room centre at the face."""
NEAR_CLIP_PLANE = 0.3
"""Near plane of the face cameras (Unity's default camera), CG units."""
FAR_PER_DISTANCE = 1000.0
"""Far plane = this times the eye-to-face distance (book: farClipPlane = distance * 1000)."""

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


# {{{ the room and its off-axis cameras


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
