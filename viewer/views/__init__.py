"""Views: how each scene's state is drawn. ``viewer/views/<stem>.py`` holds the views of chapter ``<stem>``.

A view copies the simulation's state into GL buffers (``upload``) and renders it (``draw``); it never enqueues
a kernel itself, it calls Simulation methods (``step``, ``reset``, ``update``, ``emit`` ...). Its ``keys`` table
is the only place a scene key is defined: the help overlay and the README tables are generated from it.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import ClassVar

import moderngl

from ..camera import OrbitCamera


@dataclass(frozen=True)
class Key:
    key: str
    """Key name: a letter or digit, a symbol such as "[" or "+", or space, tab, esc, up, down, left, right."""
    help: str
    action: str
    """Name of the view method (no arguments) the key calls."""


class View:
    """Base of every view."""

    title: ClassVar[str] = ""
    keys: ClassVar[tuple[Key, ...]] = ()
    background: ClassVar[tuple[float, float, float]] = (0.192, 0.302, 0.475)
    """Unity's default camera background colour."""
    steps_per_frame: ClassVar[int] = 1
    max_frame_dt: ClassVar[float | None] = 1.0 / 30.0
    """Clamp of the frame time used as dt (None: always the scene's fixed dt)."""

    def __init__(self, ctx: moderngl.Context, sim):
        self.ctx, self.sim = ctx, sim

    def make_camera(self):
        """The window's start camera (the book's, where it has one)."""
        return OrbitCamera()

    def png_camera(self):
        """The camera of ``--png`` pictures and docs images: by default the start camera."""
        return self.make_camera()

    def upload(self) -> None:
        """Copy the simulation state into GL objects."""

    def draw(self, camera) -> None:
        raise NotImplementedError

    def status(self) -> list[str]:
        """Short lines shown in the corner (counts, current mode)."""
        return []

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        """Mouse drag in window units (u, v in [0, 1], v up). 3D views orbit; 2D views inject."""
        camera.drag(du * 600, dv * 600)

    def on_release(self, camera) -> None:
        """Mouse button released."""

    def on_right_click(self, camera, u: float, v: float) -> None:
        """Right button pressed and released without a drag (a right drag orbits)."""


def view_class(scene) -> type[View]:
    module = importlib.import_module(f"{__name__}.{scene.stem}")
    return getattr(module, scene.view or "View")


def create_view(scene, ctx: moderngl.Context, sim) -> View:
    return view_class(scene)(ctx, sim)
