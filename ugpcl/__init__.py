"""ugpcl: the samples of Unity Graphics Programming vol.1, 3 and 4 as OpenCL kernels (PyOpenCL) and moderngl views.

From Python::

    import ugpcl
    print(ugpcl.list_scenes())                 # {name: what you see}
    sim = ugpcl.create("boids", seed=1, device="pocl", max_object_num=1024)
    sim.step()                                 # one step of the scene's dt
    sim.update(cohesion_weight=2.0)            # live parameters apply at the next step, others reset
    state = sim.state()                        # numpy arrays, exactly what `ugpcl run` writes to .npz
    ugpcl.render_png(sim, "boids.png")         # offscreen (EGL), the same picture as `ugpcl run --png`
    frame = ugpcl.render(sim, 640, 360)        # the same as an (H, W, 4) uint8 array; in Jupyter `sim` shows itself

docs/notebooks/quickstart.ipynb steps a scene, plots its state and shows a frame.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

from . import scene as _scene

try:
    __version__ = version("ugpcl")
except PackageNotFoundError:  # run from a source tree (PYTHONPATH), not installed
    __version__ = "0+source"

__all__ = ["__version__", "create", "list_scenes", "render", "render_png"]


def list_scenes() -> dict[str, str]:
    """{scene name: what you see}: the names ``create`` and ``ugpcl run`` take."""
    from .registry import scenes

    return {name: scene.summary for name, scene in scenes().items()}


def create(scene: str, seed: int = 0, device=None, **params):
    """A new simulation of ``scene`` (a name from ``ugpcl.list_scenes()``) with ``params`` over the scene's defaults;
    ``device`` is a device name or a ``Runtime``. Raises ValueError naming a bad scene or parameter."""
    from .registry import get
    from .runtime import Runtime

    rt = device if isinstance(device, Runtime) else Runtime.shared(device)
    return get(scene).create(rt, seed, **params)


def render(sim, width: int = 800, height: int = 600) -> np.ndarray:
    """``sim`` drawn through its scene's view offscreen (EGL), as ``ugpcl run --png`` draws it: (height, width, 4)
    uint8 RGBA, top row first (for matplotlib's ``imshow``, a video writer, a notebook)."""
    from .viewer.offscreen import render as draw

    if not (isinstance(width, int) and isinstance(height, int) and 1 <= width <= 16384 and 1 <= height <= 16384):
        raise ValueError(f"width and height must be integers in [1, 16384], got {width!r} x {height!r}")
    scene = sim.scene or type(sim).first_scene
    rgb = draw(scene, sim, (width, height))
    return np.concatenate([rgb, np.full((*rgb.shape[:2], 1), 255, np.uint8)], axis=2)


def _png_bytes(sim) -> bytes:
    """A simulation as PNG bytes (Jupyter's ``_repr_png_``): 640 x 360."""
    import io

    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(render(sim, 640, 360)).save(buffer, format="PNG")
    return buffer.getvalue()


def render_png(sim, path, size: tuple[int, int] = (800, 600)) -> Path:
    """Draw ``sim`` through its scene's view offscreen (EGL) into the PNG ``path``; returns the path."""
    from .viewer.offscreen import render_png as render

    scene = sim.scene or type(sim).first_scene  # a simulation made directly (not by create): its class's first scene
    render(scene, sim, path, tuple(size))
    return Path(path)


_scene.Simulation.picture = staticmethod(_png_bytes)  # Simulation._repr_png_ (scene.py does not import the viewer)
