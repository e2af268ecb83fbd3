"""ugpcl: the samples of Unity Graphics Programming vol.1, 3 and 4 as OpenCL kernels (PyOpenCL) and moderngl views.

From Python::

    import ugpcl
    print(ugpcl.scenes())                      # {name: what you see}
    sim = ugpcl.create("boids", seed=1, device="pocl", max_object_num=1024)
    sim.step()                                 # one step of the scene's dt
    sim.update(cohesion_weight=2.0)            # live parameters apply at the next step, others reset
    state = sim.state()                        # numpy arrays, exactly what `ugpcl run` writes to .npz
    ugpcl.render_png(sim, "boids.png")         # offscreen (EGL), the same picture as `ugpcl run --png`
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from . import scenes  # the registry; also callable: ugpcl.scenes() (see ugpcl/scenes/__init__.py)

try:
    __version__ = version("ugpcl")
except PackageNotFoundError:  # run from a source tree (PYTHONPATH), not installed
    __version__ = "0+source"

__all__ = ["__version__", "create", "render_png", "scenes"]


def create(scene: str, seed: int = 0, device=None, **params):
    """A new simulation of ``scene`` (a name from ``ugpcl.scenes()``) with ``params`` over the scene's defaults;
    ``device`` is a device name or a ``Runtime``. Raises ValueError naming a bad scene or parameter."""
    from .runtime import Runtime
    from .scenes import get

    rt = device if isinstance(device, Runtime) else Runtime.shared(device)
    return get(scene).create(rt, seed, **params)


def render_png(sim, path, size: tuple[int, int] = (800, 600)) -> Path:
    """Draw ``sim`` through its scene's view offscreen (EGL) into the PNG ``path``; returns the path."""
    from .scenes import scenes as registry
    from .viewer.offscreen import render_png as render

    # a simulation made directly (not by create) is drawn by the first scene of its class
    scene = sim.scene or next(s for s in registry().values() if s.simulation is type(sim))
    render(scene, sim, path, tuple(size))
    return Path(path)
