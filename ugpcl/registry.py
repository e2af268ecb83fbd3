"""The scene registry: every module of ``ugpcl.scenes`` is one chapter; its ``SCENES`` list names what ``ugpcl run``
can run.

Nothing is registered by hand: modules are found by file stem (as ``ti example`` finds Taichi's gallery). Only the
layers above the chapters (run, sweep, viewer, bench, cli, docs) import this; ``ugpcl.scene`` never does.
"""

from __future__ import annotations

import importlib
import pkgutil
from functools import cache
from types import ModuleType

from . import scenes as package
from .scene import Scene


@cache
def modules() -> dict[str, ModuleType]:
    return {
        info.name: importlib.import_module(f"{package.__name__}.{info.name}")
        for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda i: i.name)
        if not info.name.startswith("_")
    }


@cache
def scenes() -> dict[str, Scene]:
    found: dict[str, Scene] = {}
    for module in modules().values():
        for scene in getattr(module, "SCENES", ()):
            found[scene.name] = scene
    return found


def get(name: str) -> Scene:
    try:
        return scenes()[name]
    except KeyError:
        raise ValueError(f"unknown scene {name!r}; valid: {', '.join(scenes())}") from None
