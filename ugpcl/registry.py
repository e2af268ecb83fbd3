"""The scene registry: every module of ``ugpcl.scenes`` is one chapter; its ``SCENES`` list names what ``ugpcl run``
can run.

Nothing is registered by hand: modules are found by file stem (as ``ti example`` finds Taichi's gallery). After the
package's own, each ``*.py`` of the folders named in ``UGPCL_SCENES`` (os.pathsep-separated) is loaded as
``ugpcl.scenes.<stem>``, so a chapter of your own, written with the same relative imports as ours
(docs/adding-a-chapter.md), runs from any folder. Only the layers above the chapters (run, sweep, viewer, bench,
cli, docs) import this; ``ugpcl.scene`` never does.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import pkgutil
import sys
from functools import cache
from pathlib import Path
from types import ModuleType

from . import scenes as package
from .scene import Scene

SCENES_ENV = "UGPCL_SCENES"
"""Environment variable: folders of extra scene modules, os.pathsep-separated."""


@cache
def modules() -> dict[str, ModuleType]:
    """{stem: module}: the package's scene modules by name, then those of ``UGPCL_SCENES``'s folders."""
    found = {
        info.name: importlib.import_module(f"{package.__name__}.{info.name}")
        for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda i: i.name)
        if not info.name.startswith("_")
    }
    for path in extra_files():
        if path.stem in found:
            where = getattr(found[path.stem], "__file__", path.stem)
            raise ValueError(f"{SCENES_ENV}: {path} has the stem of the scene module {where}; rename it")
        found[path.stem] = _load(path)
    return found


def extra_files() -> list[Path]:
    """The ``*.py`` files (not ``_*.py``) of the folders ``UGPCL_SCENES`` names, folder by folder, by name."""
    files = []
    for text in os.environ.get(SCENES_ENV, "").split(os.pathsep):
        if not text:
            continue
        folder = Path(text)
        if not folder.is_dir():
            raise ValueError(f"{SCENES_ENV}: {folder} is not a folder")
        files += sorted(p for p in folder.glob("*.py") if not p.name.startswith("_"))
    return files


def _load(path: Path) -> ModuleType:
    """``path`` imported as ``ugpcl.scenes.<stem>``: a module of the package for its relative imports."""
    name = f"{package.__name__}.{path.stem}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


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
