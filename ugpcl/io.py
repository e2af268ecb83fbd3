"""Files of a run: atomic writes (``written_whole``) and the outputs of one run committed together (``Outputs``),
the .npz record of a state and how it was made, reading one back to resume with every field checked
(``load_checkpoint``), and the checks of an output path made before anything runs.

UsageError lives here, the lowest module that raises it: bad input found before a run starts (the front ends
``ugpcl`` and ``ugpcl-view`` print it as one line and exit 2).
"""

from __future__ import annotations

import json
import os
import re
import tempfile
import time
import zipfile
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__
from .geometry.mesh_io import NonFinite
from .registry import get
from .scene import Params, Scene, Simulation, check_dt


class UsageError(Exception):
    """Bad input from the command line, found before the run starts: printed as one line, exit 2."""


TEMPORARY = re.compile(r"\..*\.(\d+)-[a-z0-9_]+\.partial(\.[^.]*)?")
"""A temporary name of ``temporary_beside``: ``.STEM.PID-RANDOM.partial.SUFFIX`` (the writer's process id, so that
the next run into the folder can tell a killed run's leftovers from a running one's file)."""
STARTED = time.time()
"""When this process began writing (this module's import): a temporary file older than this and whose process is
gone is a killed run's leftover."""
UMASK = os.umask(0o022)
os.umask(UMASK)  # read the umask (Python can only read it by setting it): renamed files get the usual permissions


def temporary_beside(path: Path) -> Path:
    """A new empty file of a unique name in ``path``'s folder, ending in ``path``'s suffix (writers that go by the
    suffix still do): two runs writing one path never share it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    # the stem is cut so that the temporary name fits wherever the path's own name does
    fd, name = tempfile.mkstemp(
        dir=path.parent, prefix=f".{path.stem[:64]}.{os.getpid()}-", suffix=f".partial{path.suffix}"
    )
    os.close(fd)
    return Path(name)


def settle(temporary: Path) -> None:
    """Put a written temporary file on disk (fsync) with the permissions a new file gets (mkstemp's are 0600)."""
    fd = os.open(temporary, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    os.chmod(temporary, 0o666 & ~UMASK)


def sync_folder(folder: Path) -> None:
    """Put the renames done in ``folder`` on disk."""
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    except OSError:  # some file systems cannot sync a folder; the rename itself is still atomic
        pass
    finally:
        os.close(fd)


def remove_stale_temporaries(folder: Path) -> None:
    """Remove the temporary files a killed run left in ``folder``: named by ``temporary_beside``, older than this
    process, and their process is gone."""
    for path in folder.glob(".*.partial*"):
        match = TEMPORARY.fullmatch(path.name)
        try:
            if match and path.stat().st_mtime < STARTED and not _running(int(match[1])):
                path.unlink()
        except OSError:  # gone meanwhile, or not ours to remove
            pass


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):  # another user's process; or no pid at all
        return True
    return True


@contextmanager
def written_whole(path: Path):
    """Yield a temporary name beside ``path`` (``temporary_beside``); when the block completes, fsync it and
    rename it over ``path``; remove it otherwise. A reader never sees a half-written file, and an interrupted run
    leaves the previous one in place."""
    temporary = temporary_beside(path)
    try:
        yield temporary
        settle(temporary)
        os.replace(temporary, path)
        sync_folder(path.parent)
    finally:
        temporary.unlink(missing_ok=True)


class Outputs:
    """The files of one run, written whole and together: ``prepare`` writes each to a temporary name beside it,
    ``commit`` renames them all into place in the order they were prepared, leaving the block (``with``) removes
    what is not committed. ``written`` says what is in place, a checkpoint written during the run (``note``)
    included, so that an interrupted run can say exactly that (``summary``)."""

    def __init__(self):
        self.pending: list[tuple[Path, Path]] = []
        self.written: dict[Path, str] = {}
        self.dropped: list[Path] = []
        self.sizes: dict[Path, int] = {}
        self.folders: set[Path] = set()

    def target(self, path: Path | None) -> Path | None:
        """Declare an output before the run: a killed run's leftovers in its folder are removed."""
        if path is not None and path.parent.resolve() not in self.folders:
            self.folders.add(path.parent.resolve())
            if path.parent.is_dir():
                remove_stale_temporaries(path.parent)
        return path

    def prepare(
        self, option: str, path: Path, write: Callable[[Path], object], arrays: dict | None = None, may_be_infinite=()
    ) -> None:
        """Write ``path``'s content to a temporary file with ``write(temporary)``, after refusing NaN/inf in
        ``arrays`` (``non_finite``); a mesh writer refuses its own (NonFinite). ``option`` names it in errors."""
        if arrays is not None and (bad := non_finite(arrays, may_be_infinite)):
            raise NonFinite(f"{option} {path}: {', '.join(bad)} hold NaN or inf; {self.summary()}")
        temporary = temporary_beside(path)
        self.pending.append((path, temporary))
        try:
            write(temporary)
        except NonFinite as err:
            raise NonFinite(f"{option} {path}: {err}; {self.summary()}") from None
        settle(temporary)
        self.sizes[path] = temporary.stat().st_size

    def commit(self) -> None:
        """Rename every prepared file into place, in the order prepared."""
        while self.pending:
            path, temporary = self.pending[0]
            os.replace(temporary, path)
            self.written[path] = str(path)
            self.pending.pop(0)
        for folder in self.folders:
            sync_folder(folder)

    def note(self, path: Path, fact: str) -> None:
        """``path`` was written during the run: ``fact`` says what it holds (``checkpoint X at step N``)."""
        self.written[path] = fact

    def summary(self) -> str:
        """``nothing was written``, or ``wrote only A, B`` (and which prepared files were not)."""
        if not self.written:
            return "nothing was written"
        unwritten = [str(path) for path, _ in self.pending] + [str(path) for path in self.dropped]
        facts = ", ".join(self.written.values())
        return f"wrote only {facts}" + (f" (not {', '.join(unwritten)})" if unwritten else "")

    def __enter__(self) -> Outputs:
        return self

    def __exit__(self, *exc) -> None:
        """Remove the temporary files not committed. One already renamed (an interrupt between the rename and
        its record) counts as written."""
        for path, temporary in self.pending:
            if temporary.exists():
                temporary.unlink()
                self.dropped.append(path)
            else:
                self.written[path] = str(path)
        self.pending.clear()


def non_finite(arrays: dict, may_be_infinite: tuple[str, ...] = ()) -> list[str]:
    """Names of the floating-point arrays that hold NaN or inf (only NaN for ``may_be_infinite``)."""
    bad = []
    for key, value in arrays.items():
        if np.issubdtype(np.asarray(value).dtype, np.floating):
            finite = ~np.isnan(value) if key in may_be_infinite else np.isfinite(value)
            if not finite.all():
                bad.append(key)
    return bad


def write_npz(path: Path, arrays: dict) -> None:
    with written_whole(path) as partial, open(partial, "wb") as f:
        np.savez(f, **arrays)


def save_npz(arrays: dict, compress: bool = False):
    """A writer for ``Outputs.prepare``: ``arrays`` as a .npz (``compress``: deflated, ``np.savez_compressed``)."""
    save = np.savez_compressed if compress else np.savez

    def write(path: Path) -> None:
        with open(path, "wb") as f:
            save(f, **arrays)

    return write


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


@dataclass
class Checkpoint:
    """A ``ugpcl run`` .npz to go on from, every field checked (``load_checkpoint``); the state arrays are checked
    against the scene's own state once the simulation is open (``run.restore_checkpoint``)."""

    path: str
    scene: Scene
    params: Params
    dt: float
    seed: int
    steps: int
    sim_time: float
    arrays: dict[str, np.ndarray]


def load_checkpoint(text: str, scene: str | None = None) -> Checkpoint:
    """Read and check a ``ugpcl run`` .npz (a checkpoint or a finished run) of ``scene`` (None: any): a UsageError
    naming the check that failed otherwise: the file, the zip and its CRCs, the fields, the scene, the parameters."""

    def bad(what: str) -> UsageError:
        return UsageError(f"--resume {text}: {what}")

    if not text.strip():
        raise UsageError("--resume is empty; give the .npz of a run")
    path = Path(text)
    if not path.exists():
        raise bad("no such file")
    if path.is_dir():
        raise bad("is a folder, not a .npz")
    if path.stat().st_size == 0:
        raise bad("is empty")
    try:
        data = np.load(path, allow_pickle=False)
        if isinstance(data, np.ndarray):
            raise bad("is a single .npy array, not the .npz of a run")
        with data:
            found = {k: data[k] for k in data.files}  # np.load is lazy: read every array here, CRCs checked
    except UsageError:
        raise
    except zipfile.BadZipFile as err:
        raise bad(f"damaged or truncated ({err})") from None
    except Exception as err:  # noqa: BLE001 - whatever a damaged file makes numpy or zipfile raise is one line
        raise bad(f"cannot read it as a .npz ({type(err).__name__}: {str(err)[:200]})") from None
    missing = [k for k in ("scene", "params", "seed", "steps", "sim_time") if k not in found]
    if missing:
        raise bad(f"not written by ugpcl run (no {', '.join(missing)})")
    if "diverged" in found and np.any(found["diverged"]):
        raise bad("holds a diverged state")
    name = _scalar(found, "scene", "U", bad)
    try:
        kind = get(name)
    except ValueError:
        raise bad(f"holds scene {name!r}, which is not a scene of `ugpcl list`") from None
    if scene and scene != name:
        raise bad(f"holds scene {name}, not {scene}")
    if not kind.simulation.resumable():
        raise bad(f"scene {name} cannot resume (it does not restore its state)")
    try:
        recorded = json.loads(_scalar(found, "params", "U", bad))
    except json.JSONDecodeError as err:
        raise bad(f"params is not JSON ({err})") from None
    if not isinstance(recorded, dict):
        raise bad(f"params is not a JSON object, got {type(recorded).__name__}")
    if "dt" not in recorded:
        raise bad("params has no dt")
    dt = recorded.pop("dt")
    names = kind.simulation.Params.names()
    if unknown := sorted(set(recorded) - set(names)):
        raise bad(f"params has unknown parameter {unknown[0]!r} for scene {name}")
    if absent := [n for n in names if n not in recorded]:
        raise bad(f"params lacks {absent[0]!r} of scene {name}")
    try:
        params = kind.params(**recorded)
        dt = check_dt(dt, kind.simulation.default_dt)
    except ValueError as err:
        raise bad(f"params: {err}") from None
    seed = _scalar(found, "seed", "iu", bad)
    steps = _scalar(found, "steps", "iu", bad)
    sim_time = _scalar(found, "sim_time", "f", bad)
    if seed < 0:
        raise bad(f"seed must be >= 0, got {seed}")
    if steps < 0:
        raise bad(f"steps must be >= 0, got {steps}")
    if not (np.isfinite(sim_time) and sim_time >= 0):
        raise bad(f"sim_time must be a finite time >= 0, got {sim_time}")
    return Checkpoint(text, kind, params, dt, int(seed), int(steps), float(sim_time), found)


def _scalar(found: dict, key: str, kinds: str, bad: Callable[[str], UsageError]):
    """``found[key]`` as a Python value when it is one value of a dtype kind in ``kinds`` (U: text, iu: integer,
    f: float); ``bad(...)`` otherwise."""
    value = found[key]
    names = {"U": "text", "iu": "an integer", "f": "a float"}
    if value.shape != () or value.dtype.kind not in kinds:
        raise bad(f"{key} must be {names[kinds]}, got {value.dtype} of shape {value.shape}")
    return value.item()


def output_path(text: str | None, option: str, suffixes: tuple[str, ...]) -> Path | None:
    """Check an output file before the run: a name that fits the file system, its format by suffix, that it is
    not a folder, and that its folder exists or can be made and is writable. Nothing is written yet."""
    if text is None:
        return None
    if not text.strip():
        raise UsageError(f"{option} is empty; give a file name ending in {' or '.join(suffixes)}")
    path, full = Path(text), Path(os.path.abspath(text))
    folder = full.parent
    while not _exists(folder):  # the first folder that exists must let us make the rest
        folder = folder.parent
    _fits(full, folder, option, text)
    if path.is_dir():
        raise UsageError(f"{option} {text}: is a folder; give a file name ending in {' or '.join(suffixes)}")
    if path.suffix.lower() not in suffixes:
        raise UsageError(f"{option} must end in {' or '.join(suffixes)}, got {text!r}")
    try:  # a real file, not os.access: root passes that check in read-only mounts and /proc
        if not folder.is_dir():
            raise NotADirectoryError(20, "not a folder")
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as err:
        raise UsageError(f"{option} {text}: cannot write in {folder} ({err.strerror})") from None
    return path


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except OSError:  # a name too long to look up does not exist
        return False


def _fits(full: Path, folder: Path, option: str, text: str) -> None:
    """Refuse a name longer than the file system holds (NAME_MAX of ``folder``, the first folder that exists) and
    a path longer than PATH_MAX: before the run, rather than when it ends."""
    name_max, path_max = os.pathconf(folder, "PC_NAME_MAX"), os.pathconf(folder, "PC_PATH_MAX")
    for part in full.relative_to(folder).parts:
        if len(os.fsencode(part)) > name_max:
            raise UsageError(
                f"{option}: the name {part[:24]}... is {len(os.fsencode(part))} bytes, "
                f"over the {name_max} this file system holds"
            )
    if len(os.fsencode(str(full))) >= path_max:
        raise UsageError(f"{option}: the path is {len(os.fsencode(str(full)))} bytes, over the {path_max - 1} allowed")


def output_folder(text: str | None, option: str) -> Path | None:
    """Check a folder for numbered files before the run: not a file, and it exists or can be made, writable."""
    if text is None:
        return None
    if not text.strip():
        raise UsageError(f"{option} is empty; give a folder")
    if Path(text).exists() and not Path(text).is_dir():
        raise UsageError(f"{option} {text}: is a file; give a folder")
    output_path(str(Path(text) / "frame-000000.png"), option, (".png",))
    return Path(text)
