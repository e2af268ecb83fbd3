"""ugpcl: the samples of Unity Graphics Programming vol.1, 3 and 4 as OpenCL kernels (PyOpenCL) and moderngl views."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("ugpcl")
except PackageNotFoundError:  # run from a source tree (PYTHONPATH), not installed
    __version__ = "0+source"
