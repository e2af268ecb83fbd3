"""ugpcl: the samples of Unity Graphics Programming vol.1, 3 and 4 as OpenCL kernels (PyOpenCL) and moderngl views.

From Python::

    import ugpcl
    print(ugpcl.list_scenes())                 # {name: what you see}
    sim = ugpcl.create("boids", seed=1, device="pocl", max_object_num=1024)
    sim.step()                                 # one step of the scene's dt
    sim.update(cohesion_weight=2.0)            # live parameters apply at the next step, others reset
    state = sim.state()                        # numpy arrays, exactly what `ugpcl run` writes to .npz
    ugpcl.render_png(sim, "boids.png")         # offscreen (EGL), the same picture as `ugpcl run --png`
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

try:
    __version__ = version("ugpcl")
except PackageNotFoundError:  # run from a source tree (PYTHONPATH), not installed
    __version__ = "0+source"

__all__ = ["__version__", "create", "list_scenes", "render_png"]


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


def render_png(sim, path, size: tuple[int, int] = (800, 600)) -> Path:
    """Draw ``sim`` through its scene's view offscreen (EGL) into the PNG ``path``; returns the path."""
    from .viewer.offscreen import render_png as render

    scene = sim.scene or type(sim).first_scene  # a simulation made directly (not by create): its class's first scene
    render(scene, sim, path, tuple(size))
    return Path(path)
