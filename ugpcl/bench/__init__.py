"""``ugpcl bench``: one module per chapter (``ugpcl/bench/<stem>.py`` with ``bench(runtime, sizes) -> rows``), the
device's own benches (``device``: copy, peak, launch) and the one timing helper they share (``timing``).

Benches sit above the chapters and the viewer: a chapter's bench may time its GL pass too, and no scene module
imports anything from here. Nothing is registered by hand: a module with a ``bench`` function is a bench.
"""

from __future__ import annotations

import importlib
import pkgutil

SHARED = ("device", "timing")
"""Modules of this package that are not a chapter's bench."""


def benches() -> dict:
    """{name: bench function}: the device's (copy, peak, launch), then every chapter's, by module name."""
    from .device import bench_copy, bench_launch, bench_peak

    found = {"copy": bench_copy, "peak": bench_peak, "launch": bench_launch}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if info.name not in SHARED and not info.name.startswith("_"):
            module = importlib.import_module(f"{__name__}.{info.name}")
            if hasattr(module, "bench"):
                found[info.name] = module.bench
    return found
