"""``ugpcl list | info | params | run | sweep | bench``: the headless front end.

Results go to stdout, logs, progress and errors to stderr. Exit codes: 0 ok; 2 bad usage (unknown scene, bad
parameter, an output path that cannot be written), found before anything runs; 1 a failure while running (no
device, a build error, a pool or grid that runs out, a file that cannot be written); 130 interrupted (Ctrl-C),
143 terminated (SIGTERM). Every error is one line; an interrupted run leaves earlier output files untouched (a
file is written to a temporary name and renamed when complete).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import sys
import tempfile
import textwrap
import threading
import time
from collections import deque
from collections.abc import Callable
from contextlib import contextmanager, nullcontext
from pathlib import Path

import numpy as np
import pyopencl as cl

from . import __version__, resources
from .geometry.mesh_io import MESH_SUFFIXES
from .registry import get, scenes
from .runtime import BuildError, DeviceError, Runtime, all_devices
from .scene import ParamError, Scene, Simulation, check_dt

USAGE_ERROR, RUNTIME_ERROR, INTERRUPTED, TERMINATED = 2, 1, 130, 143
MAX_SEED = 2**63 - 1
"""Largest --seed: the .npz stores it as int64."""
CHECK_SECONDS = 2.0
"""How often a run reads its state back to look for NaN/inf (also at every --every snapshot and at the end)."""
STEPS_IN_FLIGHT = 4
"""Steps ``ugpcl run`` lets the device queue hold before it waits for the oldest: the progress bar counts
finished steps, and the host never runs far ahead of the device."""


class UsageError(Exception):
    """Bad input from the command line, found before the run starts: printed as one line, exit 2."""


class Diverged(RuntimeError):
    """The simulation produced NaN or inf: one line naming the arrays, the steps and the parameters that were set."""

    def __init__(self, first: int, last: int, arrays: list[str], state: dict):
        steps = f"step {last}" if first == last else f"steps {first} and {last}"
        super().__init__(f"diverged between {steps}: {', '.join(arrays)} hold NaN or inf")
        self.state = state


def non_finite(state: dict, may_be_infinite: tuple[str, ...] = ()) -> list[str]:
    """Names of the floating-point arrays of ``state`` that hold NaN or inf (only NaN for ``may_be_infinite``)."""
    bad = []
    for key, value in state.items():
        if np.issubdtype(np.asarray(value).dtype, np.floating):
            finite = ~np.isnan(value) if key in may_be_infinite else np.isfinite(value)
            if not finite.all():
                bad.append(key)
    return bad


class Watch:
    """Looks for NaN/inf in a simulation's state: ``check()`` reads it back (or takes one already read) and raises
    Diverged naming the steps since the last finite check; ``due()`` says CHECK_SECONDS have passed since then.
    ``ugpcl run`` and the viewer share it."""

    def __init__(self, sim: Simulation):
        self.sim, self.step, self.at = sim, sim.steps, time.monotonic()

    def due(self) -> bool:
        return time.monotonic() - self.at > CHECK_SECONDS

    def check(self, state: dict | None = None) -> dict:
        state = self.sim.state() if state is None else state
        bad = non_finite(state, self.sim.may_be_infinite)
        if bad:
            raise Diverged(self.step + 1, self.sim.steps, bad, state)
        self.step, self.at = self.sim.steps, time.monotonic()
        return state


class Terminated(Exception):
    """SIGTERM arrived: ends the run like Ctrl-C does, with exit 143 (128 + SIGTERM)."""


def _on_sigterm(signum, frame):
    raise Terminated


# {{{ tables


def terminal_width() -> int:
    """Columns of the terminal (``COLUMNS`` wins); 160 when the output is not a terminal."""
    return shutil.get_terminal_size(fallback=(160, 24)).columns


def format_table(rows: list[dict], columns: list[str] | None = None, width: int | None = None) -> str:
    """A plain-text table that fits ``width`` (default: the terminal): text left-aligned, numbers right-aligned,
    columns narrowed from the widest down and their cells wrapped at word boundaries; floats get 4 significant
    digits (or engineering form when large or small)."""
    if not rows:
        return "(no rows)"
    columns = columns or list(dict.fromkeys(k for row in rows for k in row))

    def cell(v) -> str:
        if isinstance(v, float):
            return f"{v:.3e}" if abs(v) >= 1e5 or (v != 0 and abs(v) < 1e-3) else f"{v:.4g}"
        return str(v)

    text = [[cell(row.get(c, "")) for c in columns] for row in rows]
    numeric = [all(isinstance(row.get(c), int | float) for row in rows if c in row) for c in columns]
    widths = [max(len(c), *(len(r[i]) for r in text)) for i, c in enumerate(columns)]
    # narrowest a column may get: the first (the names) stays whole; the others keep their header and words up to
    # 16 characters whole (longer words break)
    floors = [widths[0]] + [
        min(w, max(len(c), min(16, max(len(word) for r in text for word in r[i].split() or [""]))))
        for i, (c, w) in enumerate(zip(columns, widths, strict=True))
    ][1:]
    budget = (width or terminal_width()) - 2 * (len(columns) - 1)
    while sum(widths) > budget:
        i = max(range(len(widths)), key=lambda k: (widths[k] > floors[k], widths[k], k))  # the widest first
        if widths[i] <= floors[i]:
            break  # every column at its floor: let the line run long rather than lose text
        widths[i] -= 1

    def line(cells: list[str]) -> str:
        parts = [t.rjust(w) if num else t.ljust(w) for t, w, num in zip(cells, widths, numeric, strict=True)]
        return "  ".join(parts).rstrip()

    lines = [line(list(columns)), "  ".join("-" * w for w in widths)]
    for r in text:
        wrapped = [textwrap.wrap(t, w, break_on_hyphens=False) or [""] for t, w in zip(r, widths, strict=True)]
        for k in range(max(len(cell_lines) for cell_lines in wrapped)):
            lines.append(line([cell_lines[k] if k < len(cell_lines) else "" for cell_lines in wrapped]))
    return "\n".join(lines)


# }}}

# {{{ commands


def cmd_list(args) -> int:
    print(format_table([{"scene": name, "what you see": scene.summary} for name, scene in scenes().items()]))
    return 0


HLSL_TO_OPENCL = [
    ("[numthreads(tx,ty,tz)]", "__attribute__((reqd_work_group_size(tx,ty,tz)))"),
    ("Dispatch(gx,gy,gz)", "global size (gx*tx, gy*ty, gz*tz), local size (tx,ty,tz)"),
    ("SV_GroupID / SV_GroupThreadID", "get_group_id(d) / get_local_id(d)"),
    ("SV_DispatchThreadID", "get_global_id(d) = group * numthreads + local"),
    ("SV_GroupIndex", "z*tx*ty + y*tx + x of the local id"),
    ("GetKernelThreadGroupSizes", "kernel.get_work_group_info(COMPILE_WORK_GROUP_SIZE, device)"),
    ("FindKernel / SetInt / SetBuffer", "program.kernel(name) / kernel arguments"),
    ("ComputeBuffer.GetData / Release", "enqueue_copy to the host / buffer.release()"),
    ("registers", "__private variables"),
    ("groupshared + GroupMemoryBarrierWithGroupSync", "__local + barrier(CLK_LOCAL_MEM_FENCE)"),
    ("global memory (StructuredBuffer)", "__global pointers"),
    ("local memory (register spill)", "private arrays the compiler spills"),
    ("texture memory (RWTexture2D)", "image2d_t / image3d_t + sampler_t"),
    ("constant memory", "__constant and kernel scalar arguments"),
]


def cmd_info(args) -> int:
    devices = all_devices()
    print("OpenCL devices:")
    for d in devices:
        print(f"  {d.platform.name} | {d.name}  ({d.platform.version})")
    runtime = Runtime.shared(args.device)
    print("\nchosen:")
    facts = runtime.describe()
    print(format_table([{"fact": key, "value": str(value)} for key, value in facts.items()]))
    d = runtime.device
    print("\nlimits (book, ch.2 2.4.3) vs this device:")
    print(
        format_table(
            [
                {"limit": "threads per group", "book (cs_5_0)": "1024 (cs_4_x: 768)", "device": d.max_work_group_size},
                {"limit": "threads in z", "book (cs_5_0)": "64 (cs_4_x: 1)", "device": d.max_work_item_sizes[2]},
                {"limit": "groups per axis", "book (cs_5_0)": "65535", "device": "unbounded (size_t global size)"},
                {"limit": "shared memory", "book (cs_5_0)": "16 KB per group", "device": facts["local memory"]},
                {"limit": "constant memory", "book (cs_5_0)": "-", "device": facts["constant buffer"]},
                {"limit": "compute units (SMs)", "book (cs_5_0)": "-", "device": str(d.max_compute_units)},
            ]
        )
    )
    print("\nHLSL compute shader -> OpenCL (ch.2):")
    print(format_table([{"HLSL": hlsl, "OpenCL": ocl} for hlsl, ocl in HLSL_TO_OPENCL]))
    return 0


def cmd_params(args) -> int:
    scene = scene_named(args.scene)
    print(format_table(scene.table()))
    for rule in scene.limits():
        print(f"limit: {rule}")
    return 0


def scene_named(name: str) -> Scene:
    try:
        return get(name)
    except ValueError as err:  # unknown scene: the message lists the valid names
        raise UsageError(str(err)) from None


def parse_sets(scene: Scene, pairs: list[str]) -> dict:
    """``--set NAME=VALUE`` pairs converted with each field's type; UsageError names the bad one."""
    params = scene.simulation.Params
    out = {}
    for pair in pairs:
        name, sep, text = pair.partition("=")
        if not sep:
            raise UsageError(f"--set expects name=value, got {pair!r}")
        try:
            out[name.strip()] = params.parse(name.strip(), text)
        except ValueError as err:
            raise UsageError(str(err)) from None
    return out


class ProgressLines:
    """Signs of life when stderr is not a terminal (a log file, CI, a batch job): one line every ``interval``
    seconds, ``ugpcl: boids step 120/600 (20%), 31.2 steps/s, about 15 s left``. Same use as a tqdm bar."""

    def __init__(self, label: str, total: int, interval: float):
        self.label, self.total, self.interval = label, total, interval
        self.done, self.start = 0, time.monotonic()
        self.shown = self.start

    def update(self, n: int = 1) -> None:
        self.done += n
        now = time.monotonic()
        if now - self.shown >= self.interval and self.done < self.total:
            self.shown = now
            rate = self.done / (now - self.start)
            left = (self.total - self.done) / rate if rate > 0 else float("inf")
            print(
                f"ugpcl: {self.label} step {self.done}/{self.total} ({100 * self.done // self.total}%), "
                f"{rate:.3g} steps/s, about {left:.0f} s left",
                file=sys.stderr,
                flush=True,
            )

    def __enter__(self) -> ProgressLines:
        return self

    def __exit__(self, *exc) -> None:
        pass


PROGRESS_LINE_SECONDS = 5.0
"""How often a run whose stderr is not a terminal prints a progress line."""


def _progress(label: str, total: int, quiet: bool):
    """A progress bar on a terminal; a line every PROGRESS_LINE_SECONDS otherwise; nothing with ``quiet``."""
    if quiet or not sys.stderr.isatty():
        return ProgressLines(label, total, float("inf") if quiet else PROGRESS_LINE_SECONDS)
    from tqdm import tqdm

    # a pseudo-terminal may report a 0 x 0 screen (script, some CI runners): tqdm would then draw nothing
    columns, lines = shutil.get_terminal_size()
    return tqdm(total=total, unit="step", file=sys.stderr, mininterval=0.25, ncols=min(columns, 100), nrows=lines)


def run_steps(
    sim: Simulation,
    steps: int,
    dt: float,
    every: int | None = None,
    quiet: bool = False,
    checkpoint: tuple[int, Callable[[dict], None]] | None = None,
    frame: tuple[int, Callable[[], None]] | None = None,
) -> dict[str, np.ndarray]:
    """Step ``sim`` and return the final state plus, with ``every``, stacked ``<name>_history`` and ``time``.
    ``checkpoint=(K, save)`` calls ``save(state)`` after every K-th step; ``frame=(K, record)`` calls ``record()``
    before the first step and after every K-th (``--video``/``--frames``). Steps are counted from ``sim.steps``
    (a resumed run goes on from the checkpoint's count).

    ``step`` only enqueues work; a marker after each step tells when it has finished on the device, and the bar
    advances then. At most STEPS_IN_FLIGHT steps are queued ahead of the device."""
    queue = sim.runtime.queue
    frames, times = [], []
    watch = Watch(sim)

    def snapshot():
        state = watch.check()
        frames.append({k: state[k] for k in sim.history})
        times.append(sim.time)

    if every:
        snapshot()
    if frame:
        frame[1]()
    in_flight: deque[cl.Event] = deque()
    complete = cl.command_execution_status.COMPLETE
    with _progress(sim.scene.name if sim.scene else type(sim).__name__, steps, quiet) as progress:
        for i in range(1, steps + 1):
            sim.step(dt)
            if every and i % every == 0:
                snapshot()
            elif watch.due():
                watch.check()
            if frame and i % frame[0] == 0:
                frame[1]()
            if checkpoint and sim.steps % checkpoint[0] == 0 and i < steps:
                checkpoint[1](watch.check())
            in_flight.append(cl.enqueue_marker(queue))
            queue.flush()
            while in_flight and (len(in_flight) > STEPS_IN_FLIGHT or in_flight[0].command_execution_status == complete):
                in_flight.popleft().wait()
                progress.update()
        while in_flight:
            in_flight.popleft().wait()
            progress.update()
    out = dict(watch.check())
    if every:
        for key in sim.history:
            out[f"{key}_history"] = np.stack([f[key] for f in frames])
        out["time"] = np.asarray(times, np.float32)
    return out


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


def cmd_run(args) -> int:
    # {{{ everything that can be checked before the run
    resume = load_checkpoint(args.resume) if args.resume else None
    if resume is not None:
        if args.set or args.seed is not None:
            raise UsageError("--resume takes the scene, its parameters and the seed from the file; drop --set/--seed")
        if args.every:
            raise UsageError("--every cannot be combined with --resume (the history would start at the checkpoint)")
        if args.scene and args.scene != str(resume["scene"]):
            raise UsageError(f"--resume {args.resume} holds scene {resume['scene']}, not {args.scene}")
        args.scene = str(resume["scene"])
        recorded = json.loads(str(resume["params"]))
        args.dt = recorded.pop("dt") if args.dt is None else args.dt
        args.seed = int(resume["seed"])
    if not args.scene:
        raise UsageError("run needs a scene (see `ugpcl list`) or --resume FILE")
    scene = scene_named(args.scene)
    if resume is not None:
        if not scene.simulation.resumable():
            raise UsageError(f"--resume: scene {scene.name} cannot resume (it does not restore its state)")
        params = _params(scene, recorded)
    else:
        params = _params(scene, parse_sets(scene, args.set or []))
    seed = 0 if args.seed is None else args.seed
    if args.steps < 0:
        raise UsageError(f"--steps must be >= 0, got {args.steps}")
    if not 0 <= seed <= MAX_SEED:
        raise UsageError(f"--seed must be in [0, {MAX_SEED}], got {seed}")
    if args.every is not None and args.every < 1:
        raise UsageError(f"--every must be >= 1, got {args.every}")
    if args.every and not scene.simulation.history and not (args.video or args.frames):
        raise UsageError(f"--every: scene {scene.name} keeps no history arrays")
    if args.checkpoint_every is not None and args.checkpoint_every < 1:
        raise UsageError(f"--checkpoint-every must be >= 1, got {args.checkpoint_every}")
    try:
        dt = check_dt(args.dt, scene.simulation.default_dt)
    except ValueError as err:
        raise UsageError(f"--{err}") from None
    if args.mesh and not hasattr(scene.simulation, "export_mesh"):
        raise UsageError(f"--mesh: scene {scene.name} makes no mesh")
    out = output_path(args.out or f"out/{scene.name}.npz", "--out", (".npz",))
    checkpoint = output_path(
        args.checkpoint or (str(out.with_name(f"{out.stem}.checkpoint.npz")) if args.checkpoint_every else None),
        "--checkpoint",
        (".npz",),
    )
    png = output_path(args.png, "--png", (".png",))
    recording = output_path(args.video, "--video", (".mp4", ".webp")) or output_folder(args.frames, "--frames")
    if args.video and args.frames:
        raise UsageError("--video and --frames: give one (a run records one sequence)")
    mesh = output_path(args.mesh, "--mesh", MESH_SUFFIXES)
    size = parse_size(args.png_size)
    # }}}
    runtime = Runtime.shared(args.device)
    sim = open_simulation(scene, params, seed, runtime, announce=True)
    if resume is not None:
        sim.restore(resume)
        sim.steps, sim.time = int(resume["steps"]), float(resume["sim_time"])
        print(f"ugpcl: resumed {args.resume} at step {sim.steps}", file=sys.stderr)

    def save_checkpoint(state: dict) -> None:
        write_npz(checkpoint, record(sim, state, dt))

    start = time.perf_counter()
    diverged = None
    try:
        checkpoints = (args.checkpoint_every, save_checkpoint) if args.checkpoint_every else None
        history = args.every if scene.simulation.history else None  # --every of a --video alone sets its frames
        if recording:
            from .viewer.offscreen import renderer
            from .viewer.record import Recorder
        with Recorder(recording) if recording else nullcontext() as recorder:
            frames = None
            if recorder:
                render = renderer(scene, sim, size)
                frames = (args.every or 1, lambda: recorder.add(render()))
            state = run_steps(sim, args.steps, dt, history, args.quiet, checkpoints, frames)
        if recorder:
            print(f"wrote {recording} ({recorder.frames} frames)")
    except Diverged as err:
        sets = " ".join(args.set or []) or "none (the scene's defaults)"
        diverged = f"{err}; parameters set: {sets}"
        if not args.keep_diverged:
            raise RuntimeError(f"{diverged}; nothing was written (--keep-diverged writes it anyway)") from None
        state = {**err.state, "diverged": np.bool_(True)}
    runtime.finish()
    seconds = time.perf_counter() - start
    write_npz(out, record(sim, state, dt))
    print(f"wrote {out} ({args.steps} steps in {seconds:.2f} s): {', '.join(sorted(state))}")
    if diverged:  # the state is written as asked; no picture or mesh of NaN
        print(f"ugpcl: error: {diverged}", file=sys.stderr)
        return RUNTIME_ERROR
    for key, value in sim.stats().items():
        print(f"  {key}: {value}")
    write_pictures(sim, mesh, png, size, log=print)
    return 0


def open_simulation(scene: Scene, params, seed: int, runtime: Runtime, announce: bool = False) -> Simulation:
    """The simulation of one run (``ugpcl run``, each ``ugpcl sweep`` task), after checking that the device holds
    its buffers: UsageError when it does not or when the scene cannot build its state from ``params``."""
    try:
        resources.check(scene.simulation, params, runtime.device)
    except resources.ResourceError as err:
        raise UsageError(str(err)) from None
    if announce:
        print(f"ugpcl: {scene.name} on {runtime.label}", file=sys.stderr)
    try:
        sim = scene.simulation(runtime, params, seed)
    except ParamError as err:
        raise UsageError(str(err)) from None
    sim.scene = scene
    return sim


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


def write_pictures(sim: Simulation, mesh: Path | None, png: Path | None, size: tuple[int, int], log=None) -> None:
    """The mesh and the PNG of a finished run, each written whole; ``log`` is told each file written."""
    if mesh:
        with written_whole(mesh) as partial:
            sim.export_mesh(partial)
        if log:
            log(f"wrote {mesh}")
    if png:
        from .viewer.offscreen import render_png

        with written_whole(png) as partial:
            render_png(sim.scene, sim, partial, size)
        if log:
            log(f"wrote {png}")


def cmd_sweep(args) -> int:
    from .sweep import INDEX, parse_grid, parse_seeds, plan, sweep

    scene = scene_named(args.scene)
    grid = parse_grid(scene, args.grid or [])
    sets = parse_sets(scene, args.set or [])
    for name in grid.keys() & sets.keys():
        raise UsageError(f"{name} is given by both --grid and --set")
    seeds = parse_seeds(args.seeds)
    if args.steps < 0:
        raise UsageError(f"--steps must be >= 0, got {args.steps}")
    try:
        dt = check_dt(args.dt, scene.simulation.default_dt)
    except ValueError as err:
        raise UsageError(f"--{err}") from None
    mesh_suffix = f".{args.mesh.lower().lstrip('.')}" if args.mesh else None
    if mesh_suffix and mesh_suffix not in MESH_SUFFIXES:
        raise UsageError(f"--mesh must be one of {', '.join(s[1:] for s in MESH_SUFFIXES)}, got {args.mesh!r}")
    if mesh_suffix and not hasattr(scene.simulation, "export_mesh"):
        raise UsageError(f"--mesh: scene {scene.name} makes no mesh")
    out = Path(args.out)
    output_path(str(out / INDEX), "--out", (".csv",))
    common = {"steps": args.steps, "dt": dt, "png_size": parse_size(args.png_size), "device": args.device}
    jobs = plan(scene, grid, sets, seeds, out, args.png, mesh_suffix, **common)
    where = args.scheduler or "a local cluster"
    print(f"ugpcl: sweep {scene.name}: {len(jobs)} runs on {where}", file=sys.stderr)
    counts = sweep(jobs, out, args.scheduler, args.device, args.quiet)
    print(f"{out / INDEX}: {counts['ok']} ok, {counts['failed']} failed, {counts['skipped']} finished before")
    return RUNTIME_ERROR if counts["failed"] else 0


def _params(scene: Scene, overrides: dict):
    try:
        return scene.params(**overrides)
    except ValueError as err:  # a range or cross-field check of Params
        raise UsageError(str(err)) from None


def parse_size(text: str, option: str = "--png-size") -> tuple[int, int]:
    """``WxH`` (16..8192 each) as (width, height); UsageError naming ``option`` otherwise."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        if not (16 <= w <= 8192 and 16 <= h <= 8192):
            raise ValueError
    except ValueError:
        raise UsageError(f"{option} must be WxH with 16..8192 each, got {text!r}") from None
    return w, h


def bench_records(device: str, chapter: str, date: str, rows: list[dict]) -> list[dict]:
    """One record per measured number of a bench table: the row's text and integer columns as labels (variant,
    size), the float column as the figure (its name carries the unit: ``ms/step``, ``cell updates/s``) and the
    value. A "-" (no figure in this row: a host baseline has no device share) is neither."""
    records = []
    for row in rows:
        labels = {k: v for k, v in row.items() if not isinstance(v, float) and v != "-"}  # sizes are ints
        for key, value in row.items():
            if isinstance(value, float):
                figure = {"device": device, "chapter": chapter, "date": date, "labels": labels}
                records.append({**figure, "figure": key, "value": value})
    return records


def cmd_bench(args) -> int:
    from .bench import benches as all_benches
    from .bench.device import device_limits, with_shares

    benches = all_benches()
    names = list(benches) if args.all or not args.scene else args.scene
    for name in names:
        if name not in benches:
            raise UsageError(f"unknown bench {name!r}; valid: {', '.join(benches)}")
    out = output_path(args.json, "--json", (".json",))
    runtime = Runtime.shared(args.device)
    date = time.strftime("%Y-%m-%d")
    records = []
    for name in names:
        bench = benches[name]
        rows = bench(runtime, args.size)
        if any(key.endswith(("bytes/s", "flop/s")) for row in rows for key in row):
            rows = with_shares(rows, device_limits(runtime))
        print(f"\n## {name}  ({runtime.label}, {date})")
        print(" ".join(bench.__doc__.split()))
        print(format_table(rows))
        sys.stdout.flush()
        records += bench_records(runtime.label, name, date, rows)
    if out:
        with written_whole(out) as partial:
            partial.write_text(json.dumps(records, indent=1) + "\n")
        print(f"\nwrote {out} ({len(records)} figures)")
    return 0


# }}}


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows ``(default: X)`` once, and not at all for options whose absence is their default (None, False)."""

    def _get_help_string(self, action) -> str:
        if action.default is None or action.default is False or "default:" in (action.help or ""):
            return action.help or ""
        return super()._get_help_string(action)


def build_parser() -> argparse.ArgumentParser:
    fmt = HelpFormatter
    device = argparse.ArgumentParser(add_help=False)
    device.add_argument(
        "--device",
        default=None,
        metavar="NAME",
        help="OpenCL device: a substring of 'platform | device' such as pocl or nvidia (also UGPCL_DEVICE; "
        "unset: PYOPENCL_CTX, then the first GPU, then the first CPU)",
    )
    parser = argparse.ArgumentParser(
        prog="ugpcl", description=__doc__.splitlines()[0], formatter_class=fmt, allow_abbrev=False
    )
    parser.add_argument("--version", action="version", version=f"ugpcl {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    def command(name: str, help: str, func, parents=()):
        p = sub.add_parser(name, help=help, formatter_class=fmt, allow_abbrev=False, parents=list(parents))
        p.set_defaults(func=func)
        return p

    command("list", "scenes and what they show", cmd_list)
    command("info", "OpenCL devices, the chosen one and why, HLSL-to-OpenCL mapping", cmd_info, [device])
    command("params", "a scene's parameters: default, range, meaning", cmd_params).add_argument("scene")

    p = command("run", "run a scene headless and write its state to .npz", cmd_run, [device])
    p.add_argument("scene", nargs="?", help="a scene of `ugpcl list` (optional with --resume)")
    p.add_argument("--steps", type=int, default=300, help="simulation steps")
    p.add_argument("--seed", type=int, default=None, help="random seed (same seed + device = same result; default: 0)")
    p.add_argument("--dt", type=float, default=None, help="time step in seconds (default: the scene's own)")
    p.add_argument(
        "--set", action="extend", nargs="+", metavar="NAME=VALUE", help="override parameters (see `ugpcl params`)"
    )
    p.add_argument("--every", type=int, default=None, metavar="K", help="also keep every K-th state as *_history")
    p.add_argument("--out", default=None, help="output .npz (default: out/SCENE.npz)")
    p.add_argument("--png", default=None, help="also render the final state to this PNG (offscreen, EGL)")
    p.add_argument("--png-size", default="800x600", help="PNG size WxH (also of --video and --frames frames)")
    p.add_argument(
        "--video",
        default=None,
        metavar="FILE.mp4|.webp",
        help="record the run offscreen to an MP4 (30 fps) or a looping animated WebP: the first state, then every "
        "--every K steps (default 1)",
    )
    p.add_argument(
        "--frames", default=None, metavar="DIR", help="as --video, to DIR/frame-000000.png, frame-000001.png ..."
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress bar (on a terminal) or progress lines every few seconds (otherwise) on stderr",
    )
    p.add_argument("--mesh", default=None, help="export the scene's geometry (.obj/.ply) where it makes one")
    p.add_argument(
        "--checkpoint-every",
        type=int,
        default=None,
        metavar="K",
        help="write the state after every K-th step (atomically) to --checkpoint, for long runs",
    )
    p.add_argument("--checkpoint", default=None, help="checkpoint .npz (default: OUT with .checkpoint.npz)")
    p.add_argument(
        "--resume",
        default=None,
        metavar="FILE",
        help="go on from a checkpoint or earlier --out of a scene that can resume: --steps more steps",
    )
    p.add_argument(
        "--keep-diverged",
        action="store_true",
        help="when the state turns NaN/inf, still write it (with diverged=True) before exiting 1",
    )

    p = command("sweep", "run a scene over a parameter grid and seeds as Dask tasks", cmd_sweep, [device])
    p.add_argument("scene", help="a scene of `ugpcl list`")
    p.add_argument(
        "--grid",
        action="append",
        metavar="NAME=V1,V2",
        help="a parameter and its values (tuples: V1/V2, each comma-separated); every combination is run",
    )
    p.add_argument("--seeds", default="0", help="seeds and ranges: 0-9 or 1,4,7-9")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for RUN.npz files and index.csv")
    p.add_argument("--steps", type=int, default=300, help="simulation steps of each run")
    p.add_argument("--dt", type=float, default=None, help="time step in seconds (default: the scene's own)")
    p.add_argument("--set", action="extend", nargs="+", metavar="NAME=VALUE", help="parameters every run shares")
    p.add_argument("--png", action="store_true", help="also render each final state to RUN.png (offscreen, EGL)")
    p.add_argument("--png-size", default="800x600", help="PNG size WxH")
    p.add_argument("--mesh", default=None, metavar="EXT", help="also export each run's geometry as RUN.EXT (obj, ply)")
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="a running dask scheduler (tcp://host:port) to run on (default: a local cluster, one worker per GPU "
        "or two on a CPU device)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar or progress lines on stderr")

    p = command("bench", "time scenes and print throughput tables", cmd_bench, [device])
    p.add_argument("scene", nargs="*", help="copy, peak, launch or chapter stems (none: all)")
    p.add_argument("--all", action="store_true", help="every bench")
    p.add_argument("--size", type=int, nargs="+", default=None, help="problem sizes (default: the chapter's)")
    p.add_argument("--json", default=None, metavar="FILE", help="also write every figure of the tables to FILE.json")
    return parser


def report(prog: str, err: BaseException) -> str:
    """One line for an error that ends a run: its message's first line, with the exception's kind where the
    message alone would not say what failed."""
    text = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
    if isinstance(err, cl.Error | MemoryError | ArithmeticError):
        text = f"{type(err).__name__}: {text}"
    return f"{prog}: error: {text}"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    # SIGTERM ends a run as Ctrl-C does (old outputs untouched); the caller's handler is restored afterwards
    previous = (
        signal.signal(signal.SIGTERM, _on_sigterm) if threading.current_thread() is threading.main_thread() else None
    )
    try:
        code = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here, inside the try, rather than at exit
        return code
    except UsageError as err:
        print(f"ugpcl: error: {err}", file=sys.stderr)
        return USAGE_ERROR
    except (DeviceError, BuildError) as err:
        print(f"ugpcl: {err}", file=sys.stderr)
        return RUNTIME_ERROR
    except (ValueError, ArithmeticError, RuntimeError, cl.Error, OSError, MemoryError) as err:
        if isinstance(err, BrokenPipeError):
            return quiet_broken_pipe()
        print(report("ugpcl", err), file=sys.stderr)
        return RUNTIME_ERROR
    except KeyboardInterrupt:
        print("ugpcl: interrupted; nothing was written", file=sys.stderr)
        return INTERRUPTED
    except Terminated:
        print("ugpcl: terminated (SIGTERM); nothing was written", file=sys.stderr)
        return TERMINATED
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def quiet_broken_pipe() -> int:
    """The reader of our stdout went away (``ugpcl params boids | head -1``): stop quietly. stdout is pointed at
    /dev/null so that Python's flush at exit does not raise again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return 0


if __name__ == "__main__":
    sys.exit(main())
