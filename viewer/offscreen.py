"""Offscreen rendering through EGL (no window, no display): ``ugpcl run --png`` and the view tests."""

from __future__ import annotations

from functools import cache

import moderngl
import numpy as np

from ugpcl.runtime import all_devices

from .gl import read_pixels, save_png
from .views import View, create_view

PICTURE_ASPECT = 16 / 9
"""The aspect the views' ``png_camera`` frames a scene for (the 1280x720 previews): a narrower picture (the default
800x600 ``--png``) widens the vertical field of view instead of cropping the sides."""
MSAA_SAMPLES = 4
"""Multisampling of offscreen frames (thin lines and small boids alias badly without it)."""


@cache
def context() -> moderngl.Context:
    """One standalone EGL context per process (Mesa llvmpipe here, the NVIDIA driver on the GPU machine)."""
    all_devices()  # OpenCL before GL: PoCL aborts if it loads LLVM after Mesa did (see runtime.all_devices)
    return moderngl.create_context(standalone=True, backend="egl", require=430)


class Frame:
    """A multisampled colour+depth target of ``size`` and a plain one to resolve it into for reading."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int]):
        self.ctx, self.size = ctx, size
        samples = min(MSAA_SAMPLES, ctx.max_samples)
        self.msaa = ctx.framebuffer(
            color_attachments=[ctx.renderbuffer(size, 4, samples=samples)],
            depth_attachment=ctx.depth_renderbuffer(size, samples=samples),
        )
        self.resolved = ctx.framebuffer(color_attachments=[ctx.renderbuffer(size, 4)])

    def draw(self, view: View, camera) -> None:
        """The view's frame into the multisampled target (what a window shows)."""
        self.msaa.use()
        self.ctx.viewport = (0, 0, *self.size)
        self.ctx.clear(*view.background, 1.0, depth=1.0)
        view.draw(camera)

    def read(self) -> np.ndarray:
        """The drawn frame resolved and read back as (H, W, 3) uint8, top row first (what a picture needs)."""
        self.ctx.copy_framebuffer(self.resolved, self.msaa)
        return read_pixels(self.resolved)

    def render(self, view: View, camera) -> np.ndarray:
        self.draw(view, camera)
        return self.read()


@cache
def frame(size: tuple[int, int]) -> Frame:
    """One Frame per size, kept: releasing the bound framebuffer leaves moderngl binding a dead one on the next."""
    return Frame(context(), size)


def render(scene, sim, size: tuple[int, int] = (800, 600), view: View | None = None, camera=None) -> np.ndarray:
    """The scene's view of ``sim`` as (H, W, 3) uint8, top row first."""
    ctx = context()
    view = view or create_view(scene, ctx, sim)
    camera = camera or view.png_camera()
    camera.aspect = size[0] / size[1]
    if hasattr(camera, "framed_aspect"):  # views frame their pictures at 16:9 (the previews): keep the sides in
        camera.framed_aspect = PICTURE_ASPECT
    view.upload()
    return frame(tuple(size)).render(view, camera)


def render_png(scene, sim, path, size: tuple[int, int] = (800, 600)) -> np.ndarray:
    pixels = render(scene, sim, size)
    save_png(pixels, path)
    return pixels


def renderer(scene, sim, size: tuple[int, int] = (800, 600)):
    """A function that renders ``sim``'s current state each call, through one view and camera for the whole run
    (``ugpcl run --video/--frames``): a view keeps GL buffers, and a camera the framing, from frame to frame."""
    view = create_view(scene, context(), sim)
    camera = view.png_camera()
    return lambda: render(scene, sim, size, view, camera)
