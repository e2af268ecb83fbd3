"""MultiPlane perspective projection: a room whose walls and floor show one CG world seamlessly, from a tracked eye
(vol.1 ch.9; docs/chapters/09-multiplane-projection.md).

Each face of the room (4 walls and the floor, the book's room; ``faces=6`` adds the ceiling) gets a camera at the
eye whose frustum has exactly that face as its base: vertical FOV = 2 atan2(H/2, d), aspect = W/H (Listing 9.1)
and the eye's offset from the face centre as a lens shift in entries [0,2], [1,2] of the projection matrix
(Listing 9.2). The frusta share their apex and touch along the room's edges, so from the eye the images join into
one picture. All geometry is in Unity's (left-handed, y up) coordinates; the host maths in
ugpcl/geometry/multiplane_projection.py is the one source of the matrices (the viewer draws with them, the kernels get
their entries).

Per step (the book's CameraGenerator.Update): recompute every face camera from scratch (``face_cameras``); the
face images are made when asked for: ``RenderFaces`` (the world ray-marched through every face camera), then for
the eye's own picture ``RenderEyeDirect`` (the ideal view) and ``CompositeEyeView`` (the room as the viewer sees it).
The interactive viewer renders the faces with GL instead (viewer/views/multiplane_projection.py).

Differences from the book: the CG world is a small analytic one (ground, boxes, spheres; the book's is a
third-party city); the eye is measured from the room's centre when the matrices are made (the original measures it
from the floor pivot, which moves the windows 2.5 m down; docs page, "What differs"); the ceiling is optional.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl.cltypes as cltypes

from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..geometry.multiplane_projection import (
    SHAPE_DTYPE,
    FaceCameras,
    eye_camera,
    face_cameras,
    room_faces,
    world_record,
    world_shapes,
)
from ..resources import Allocation
from ..scene import Animation, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

MIN_WALL_DISTANCE = 0.05
"""The eye stays this far (metres) inside every face: at d -> 0 the FOV -> 180 degrees and the frustum degenerates."""

MARCH_STEPS = 128
"""Sphere-tracing steps per ray before it is taken as a miss (build define of multiplane_projection.cl)."""
SURFACE_EPSILON = 0.01
"""A ray hits a shape closer than this, CG units (build define)."""
MAX_DISTANCE = 10000.0
"""Rays end here and show the sky, CG units (build define)."""


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


class Simulation(BaseSimulation):
    """The room's face cameras for the current eye; face images and eye views rendered on demand."""

    Params = Params

    @classmethod
    def allocations(cls, params: Params) -> list[Allocation]:
        """The faces' images (RGBA8) and the eye's two, on the device and read back for the state."""
        (width, height), (view_width, view_height) = params.face_resolution, params.view_resolution
        faces = params.faces * width * height * 4
        views = view_width * view_height * 4
        return [
            Allocation("face images", faces, "face_resolution"),
            Allocation("view image", views, "view_resolution", count=2),
            Allocation("face images read back (host)", faces, "face_resolution", host=True),
        ]

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


SCENES = [
    Scene(
        "multiplane_projection",
        Simulation,
        "Room projection: 5 (or 6) off-axis face cameras from one eye, seamless from the eye (vol.1 ch.9)",
        preview={"steps": 1},
        interactive={"face_resolution": (256, 128)},  # 1024 x 512 faces march at ~3.5 s a frame on 2 PoCL cores
        animation=Animation(
            "the room and its projected walls do not change with time, so the camera swings round the room", swing=30.0
        ),
    )
]
