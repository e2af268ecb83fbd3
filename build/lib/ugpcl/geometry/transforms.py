"""Homogeneous 4x4 transforms in the maths convention (numpy row-major, ``m @ v``), shared by the scenes (which
compute what a shader will do, for tests and headless runs) and the viewer's cameras."""

from __future__ import annotations

import math

import numpy as np


def translation(x: float, y: float, z: float) -> np.ndarray:
    m = np.identity(4)
    m[:3, 3] = (x, y, z)
    return m


def euler_matrix(x_degrees: float, y_degrees: float, z_degrees: float = 0.0) -> np.ndarray:
    """Unity's Quaternion.Euler(x, y, z) as a 4x4 matrix: rotation about Z, then X, then Y (R = Ry Rx Rz)."""
    rx, ry, rz = np.radians([x_degrees, y_degrees, z_degrees])
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    mx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    my = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    mz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    m = np.identity(4)
    m[:3, :3] = my @ mx @ mz
    return m


def perspective(fov_y_degrees: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL projection matrix (clip z in [-w, w]) for a camera looking down -z."""
    f = 1.0 / math.tan(math.radians(fov_y_degrees) / 2.0)
    return np.array(
        [
            [f / aspect, 0, 0, 0],
            [0, f, 0, 0],
            [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
            [0, 0, -1, 0],
        ]
    )


def orthographic(left: float, right: float, bottom: float, top: float, near: float = -1.0, far: float = 1.0):
    return np.array(
        [
            [2 / (right - left), 0, 0, -(right + left) / (right - left)],
            [0, 2 / (top - bottom), 0, -(top + bottom) / (top - bottom)],
            [0, 0, -2 / (far - near), -(far + near) / (far - near)],
            [0, 0, 0, 1],
        ]
    )


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    forward = target - eye
    forward /= np.linalg.norm(forward)
    side = np.cross(forward, up)
    if np.linalg.norm(side) < 1e-9:  # looking straight up or down: any side vector will do
        side = np.cross(forward, (0.0, 0.0, 1.0))
    side /= np.linalg.norm(side)
    true_up = np.cross(side, forward)
    view = np.identity(4)
    view[0, :3], view[1, :3], view[2, :3] = side, true_up, -forward
    view[:3, 3] = -view[:3, :3] @ eye
    return view
