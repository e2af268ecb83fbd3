"""Files of a run: atomic writes, the .npz record of a state and how it was made, reading one back to resume, and
the checks of an output path made before anything runs.

UsageError lives here, the lowest module that raises it: bad input found before a run starts (the front ends
``ugpcl`` and ``ugpcl-view`` print it as one line and exit 2).
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from . import __version__
from .scene import Simulation


class UsageError(Exception):
    """Bad input from the command line, found before the run starts: printed as one line, exit 2."""


@contextmanager
def written_whole(path: Path):
    """Yield a temporary name beside ``path`` (same suffix, so writers that go by it still do); rename it over
    ``path`` when the block completes, remove it otherwise. A reader never sees a half-written file, and an
    interrupted run leaves the previous one in place."""
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f".{path.stem}.partial{path.suffix}")
    try:
        yield partial
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)


def write_npz(path: Path, arrays: dict) -> None:
    with written_whole(path) as partial, open(partial, "wb") as f:
        np.savez(f, **arrays)


def record(sim: Simulation, state: dict, dt: float) -> dict:
    """What a .npz holds: the state and how it was made."""
    return {
        **state,
        "params": np.array(sim.params.to_json(dt=dt)),
        "scene": np.array(sim.scene.name),
        "seed": np.int64(sim.seed),
        "steps": np.int64(sim.steps),
        "sim_time": np.float64(sim.time),
        "device": np.array(sim.runtime.label),
        "ugpcl_version": np.array(__version__),
    }


def load_checkpoint(text: str) -> dict[str, np.ndarray]:
    """The arrays of a ``ugpcl run`` .npz (a checkpoint or a finished run) to go on from; UsageError otherwise."""
    try:
        with np.load(text) as data:
            found = {k: data[k] for k in data.files}
    except (OSError, ValueError) as err:
        raise UsageError(f"--resume {text}: cannot read it as a .npz ({err})") from None
    missing = [k for k in ("scene", "params", "seed", "steps", "sim_time") if k not in found]
    if missing:
        raise UsageError(f"--resume {text}: not written by ugpcl run (no {', '.join(missing)})")
    if found.get("diverged", False):
        raise UsageError(f"--resume {text}: holds a diverged state")
    return found


def output_path(text: str | None, option: str, suffixes: tuple[str, ...]) -> Path | None:
    """Check an output file before the run: its format by suffix, that it is not a folder, and that its folder
    exists or can be made and is writable. Nothing is written yet."""
    if text is None:
        return None
    path = Path(text)
    if path.is_dir():
        raise UsageError(f"{option} {text}: is a folder; give a file name ending in {' or '.join(suffixes)}")
    if path.suffix.lower() not in suffixes:
        raise UsageError(f"{option} must end in {' or '.join(suffixes)}, got {text!r}")
    folder = path.parent.resolve()
    while not folder.exists():  # the first folder that exists must let us make the rest
        folder = folder.parent
    try:  # a real file, not os.access: root passes that check in read-only mounts and /proc
        if not folder.is_dir():
            raise NotADirectoryError(20, "not a folder")
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as err:
        raise UsageError(f"{option} {text}: cannot write in {folder} ({err.strerror})") from None
    return path


def output_folder(text: str | None, option: str) -> Path | None:
    """Check a folder for numbered files before the run: not a file, and it exists or can be made, writable."""
    if text is None:
        return None
    if Path(text).exists() and not Path(text).is_dir():
        raise UsageError(f"{option} {text}: is a file; give a folder")
    output_path(str(Path(text) / "frame-000000.png"), option, (".png",))
    return Path(text)
