"""The blog's CPU tree (B. Olij's "Space Colonization Algorithm Part 1", 2014; vol.4 ch.1's CPU counterpart): green
attraction points, brown vertices and segments, turning about y as the blog's demo does."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np

from ..camera import OrbitCamera
from ..gl import Lines
from . import Key
from . import View as BaseView
from .space_colonization import Points


class View(BaseView):
    """The blog's demo: green attraction points, brown vertices and segments, turning 50 degrees/s about y."""

    title = "Space colonization on the CPU (the blog)"
    background = (0.0, 0.0, 0.0)
    keys = (
        Key("a", "attraction points on/off", "toggle_points"),
        Key("o", "auto-rotation on/off", "toggle_rotation"),
        Key("g", "repeat guard on/off (restarts)", "toggle_repeat_guard"),
        Key("c", "clear the crown's leftover points before the roots on/off (restarts)", "toggle_clear"),
        Key("+", "branch size x 1.25 (restarts)", "longer_branches"),
        Key("-", "branch size / 1.25 (restarts)", "shorter_branches"),
        Key("e", "export the segments to out/space_colonization_cpu.obj", "export"),
    )
    ROTATION_PER_FRAME = 50.0 / 60.0
    """Degrees per drawn frame (the blog demo: 50 degrees/s)."""

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.segments = Lines(ctx, color=(204 / 256, 102 / 256, 0.0, 1.0))
        self.vertices = Points(ctx)
        self.attractions = Points(ctx)
        self.show_points, self.rotate = True, True

    def make_camera(self):
        # the blog: FOV 45, the tree moved by (0, -150, -400) in front of a GL (right-handed) camera; looking at
        # y = 120 instead of 150 keeps the roots in a 4:3 window
        return OrbitCamera(
            target=(0.0, 120.0, 0.0), distance=400.0, yaw=180.0, fov=45.0, near=1.0, far=2000.0, left_handed=False
        )

    def png_camera(self):
        return OrbitCamera(
            target=(0.0, 105.0, 0.0),
            distance=330.0,
            yaw=150.0,
            pitch=8.0,
            fov=45.0,
            near=1.0,
            far=2000.0,
            left_handed=False,
        )

    def upload(self) -> None:
        tree = self.sim.tree
        segments = np.asarray(tree.segments, np.int64).reshape(-1, 2)
        self.segments.set(tree.vertices[segments].reshape(-1, 3))
        self.vertices.set(tree.vertices)
        self.attractions.set(tree.points)

    def draw(self, camera) -> None:
        identity = np.identity(4)
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.segments.draw(camera)
        self.vertices.draw(camera, identity, (170 / 256, 80 / 256, 0.0, 1.0), 3.0)
        if self.show_points:
            self.attractions.draw(camera, identity, (0.0, 1.0, 0.0, 1.0), 2.0)
        if self.rotate:
            camera.yaw += self.ROTATION_PER_FRAME

    def status(self) -> list[str]:
        s = self.sim.stats()
        return [
            f"stage {s['stage']}  vertices {s['vertices']}  points left {s['points left']}  "
            f"iterations {s['iterations (crown, roots)']}  stalled {s['stalled (crown, roots)']}"
        ]

    def toggle_points(self) -> None:
        self.show_points = not self.show_points

    def toggle_rotation(self) -> None:
        self.rotate = not self.rotate

    def toggle_repeat_guard(self) -> None:
        self.sim.update(repeat_guard=not self.sim.params.repeat_guard)

    def toggle_clear(self) -> None:
        self.sim.update(clear_leftovers=not self.sim.params.clear_leftovers)

    def longer_branches(self) -> None:
        self.sim.update(branch_size=self.sim.params.branch_size * 1.25)

    def shorter_branches(self) -> None:
        self.sim.update(branch_size=self.sim.params.branch_size / 1.25)

    def export(self) -> None:
        path = Path("out") / "space_colonization_cpu.obj"
        self.sim.export_mesh(path)
        print(f"ugpcl-view: wrote {path}")
