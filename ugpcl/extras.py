"""Which optional parts of ugpcl are installed: the bare package runs scenes headless to .npz; pictures, meshes,
the window, videos and sweeps come with extras (setup.cfg). A command that needs a missing one is refused before it
runs, in one line naming the extra to install (exit 2), rather than failing with an ImportError half-way."""

from __future__ import annotations

from importlib.util import find_spec

from .io import UsageError

EXTRAS = {
    "render": ("moderngl", "PIL", "trimesh", "matplotlib"),
    "viewer": ("moderngl", "PIL", "moderngl_window", "pyglet", "imgui_bundle"),
    "video": ("moderngl", "PIL", "imageio", "imageio_ffmpeg"),
    "sweep": ("dask", "distributed"),
}
"""Each extra and the modules a command that needs it imports."""


class MissingExtra(UsageError):
    """A command needs an extra that is not installed."""


def missing(extra: str, modules: tuple[str, ...] | None = None) -> list[str]:
    """The modules of ``extra`` (or just ``modules`` of it) that cannot be imported here."""
    return [m for m in (modules or EXTRAS[extra]) if find_spec(m) is None]


def require(what: str, extra: str, modules: tuple[str, ...] | None = None) -> None:
    """Refuse ``what`` (an option, a command) in one line when ``extra`` (or ``modules`` of it) is not installed."""
    gone = missing(extra, modules)
    if gone:
        raise MissingExtra(
            f"{what} needs the {extra} extra ({', '.join(gone)} not installed): pip install 'ugpcl[{extra}]'"
        )
