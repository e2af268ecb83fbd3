"""Cameras: matrices in the maths convention (numpy row-major, ``m @ v``); ``gl_bytes`` transposes for GLSL.

The book's scenes live in Unity's left-handed world (+z into the screen). ``OrbitCamera(left_handed=True)``
keeps those coordinates as they are and mirrors z in the view matrix, so a scene looks as it does in Unity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ugpcl.geometry.transforms import look_at, orthographic, perspective  # noqa: F401 (the views' import place)


def gl_bytes(matrix: np.ndarray) -> bytes:
    """A maths-convention matrix as the column-major bytes a GLSL ``mat4`` uniform expects."""
    return np.ascontiguousarray(matrix.T, dtype="f4").tobytes()


MIRROR_Z = np.diag([1.0, 1.0, -1.0, 1.0])


@dataclass
class OrbitCamera:
    """Orbit around ``target``: drag turns (yaw, pitch), the wheel zooms. ``eye()`` is in scene coordinates."""

    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    distance: float = 10.0
    yaw: float = 0.0
    """Degrees about +y; 0 puts the eye on the -z side of the target (Unity's default camera side)."""
    pitch: float = 0.0
    """Degrees above the target's horizon."""
    fov: float = 60.0
    near: float = 0.3
    far: float = 1000.0
    left_handed: bool = True
    aspect: float = field(default=16 / 9)
    framed_aspect: float | None = None
    """The aspect the scene was framed for: a narrower picture widens the vertical field of view so that the sides
    stay in, rather than cropping them (pictures set it: ``ugpcl.viewer.offscreen.render``); None: ``fov`` as is."""

    def vertical_fov(self) -> float:
        """``fov``, widened when the picture is narrower than ``framed_aspect`` (the horizontal field kept)."""
        if self.framed_aspect is None or self.aspect >= self.framed_aspect:
            return self.fov
        half = math.tan(math.radians(self.fov) / 2) * self.framed_aspect / self.aspect
        return math.degrees(2 * math.atan(half))

    def eye(self) -> np.ndarray:
        yaw, pitch = math.radians(self.yaw), math.radians(self.pitch)
        offset = np.array([math.sin(yaw) * math.cos(pitch), math.sin(pitch), -math.cos(yaw) * math.cos(pitch)])
        return np.asarray(self.target, float) + self.distance * offset

    def view(self) -> np.ndarray:
        if not self.left_handed:
            return look_at(self.eye(), self.target)
        mirror = MIRROR_Z[:3, :3]
        return look_at(mirror @ self.eye(), mirror @ np.asarray(self.target, float)) @ MIRROR_Z

    def projection(self) -> np.ndarray:
        return perspective(self.vertical_fov(), self.aspect, self.near, self.far)

    def drag(self, dx: float, dy: float) -> None:
        self.yaw += dx * 0.3
        self.pitch = float(np.clip(self.pitch + dy * 0.3, -89.0, 89.0))

    def zoom(self, steps: float) -> None:
        self.distance = float(np.clip(self.distance * 0.9**steps, self.near * 2, self.far / 2))

    def fit(self, points, fill: float = 0.85, centre: bool = True) -> None:
        """Frame ``points`` (n, 3) with ``yaw`` and ``pitch`` kept: the eye moves along its line to the target to
        the distance at which every point lands within ``fill`` of the picture's half-width and half-height at
        ``framed_aspect`` (else ``aspect``; a picture keeps that horizontal field at any aspect). The rotation of
        ``view()`` does not depend on the distance, so that distance is exact: a point q (camera axes, relative to
        the target) needs |q_x| <= fill tan_h (d - q_z), and the same for y. With ``centre`` the target first
        slides sideways (a few rounds) until the points' projection is centred in the picture."""
        points = np.asarray(points, float).reshape(-1, 3)
        if not len(points):
            return
        rotation = self.view()[:3, :3]
        tan_v = math.tan(math.radians(self.fov) / 2)
        tan_h = tan_v * (self.framed_aspect or self.aspect)  # a png camera is made at 16:9, framed later

        def place() -> np.ndarray:
            q = (points - np.asarray(self.target, float)) @ rotation.T
            need = np.maximum(np.abs(q[:, 0]) / (fill * tan_h), np.abs(q[:, 1]) / (fill * tan_v))
            self.distance = float(max((q[:, 2] + need).max(), (q[:, 2] + 2 * self.near).max(), self.near * 2))
            return q

        for _ in range(3 if centre else 0):
            q = place()
            x, y = (q[:, :2] / (self.distance - q[:, 2:3])).T  # tangents of the angles off the view axis
            shift = (x.min() + x.max()) / 2 * rotation[0] + (y.min() + y.max()) / 2 * rotation[1]
            self.target = tuple(float(c) for c in np.asarray(self.target, float) + self.distance * shift)
        place()


@dataclass
class OrthoCamera(OrbitCamera):
    """An orbit camera with an orthographic projection of half-height ``half_height`` (Unity's orthographic size);
    the wheel changes that size."""

    half_height: float = 5.0
    min_half_width: float = 0.0
    """Half-width always shown: a narrow window grows the height instead of cropping the sides."""

    def projection(self) -> np.ndarray:
        framed = self.half_height * (self.framed_aspect or 0.0) / self.aspect
        h = max(self.half_height, self.min_half_width / self.aspect, framed)
        return orthographic(-h * self.aspect, h * self.aspect, -h, h, self.near, self.far)

    def zoom(self, steps: float) -> None:
        self.half_height = float(np.clip(self.half_height * 0.9**steps, 0.1, 500.0))


@dataclass
class FlatCamera:
    """A 2D view of the rectangle ``[x0, x1] x [y0, y1]``, letter-boxed to keep its aspect."""

    rect: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 1.0)
    aspect: float = 1.0

    def view(self) -> np.ndarray:
        return np.identity(4)

    def projection(self) -> np.ndarray:
        x0, x1, y0, y1 = self.rect
        cx, cy, w, h = (x0 + x1) / 2, (y0 + y1) / 2, x1 - x0, y1 - y0
        if w / h < self.aspect:
            w = h * self.aspect
        else:
            h = w / self.aspect
        return orthographic(cx - w / 2, cx + w / 2, cy - h / 2, cy + h / 2)

    def to_world(self, u: float, v: float) -> tuple[float, float]:
        """Window coordinates in [0, 1] (v up) to scene coordinates."""
        inverse = np.linalg.inv(self.projection())
        x, y, _, _ = inverse @ np.array([2 * u - 1, 2 * v - 1, 0.0, 1.0])
        return float(x), float(y)

    def drag(self, dx: float, dy: float) -> None:
        """2D views use the drag for the scene's own input (views override on_drag)."""

    def zoom(self, steps: float) -> None:
        pass
