"""Scene registry: every module here is one chapter; its ``SCENES`` list names what ``ugpcl run`` can run.

Nothing is registered by hand: modules are found by file stem (as ``ti example`` finds Taichi's gallery).
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
from functools import cache
from types import ModuleType

from ..scene import Scene


@cache
def modules() -> dict[str, ModuleType]:
    return {
        info.name: importlib.import_module(f"{__name__}.{info.name}")
        for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name)
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


class _CallableRegistry(ModuleType):
    """This module, callable: ``ugpcl.scenes()`` is the public list of scenes (the package ``ugpcl.scenes`` and the
    function could not otherwise share the name)."""

    def __call__(self) -> dict[str, str]:
        """{scene name: what you see}, for ``ugpcl.create``."""
        return {name: scene.summary for name, scene in scenes().items()}


sys.modules[__name__].__class__ = _CallableRegistry
