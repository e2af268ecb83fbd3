"""``ugpcl list | info | params | run | sweep | bench``: the headless front end.

Results go to stdout, logs, progress and errors to stderr. Exit codes: 0 ok; 2 bad usage (unknown scene, bad
parameter, an output path that cannot be written), found before anything runs; 1 a failure while running (no
device, a build error, a pool or grid that runs out, a file that cannot be written); 130 interrupted (Ctrl-C),
143 terminated (SIGTERM). Every error is one line (a usage error two: the short usage and the error). The
outputs of a run are written to temporary names and renamed together at its end (``io.Outputs``); an interrupted
run says exactly which files it had written, and every other file is the previous one.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from contextlib import nullcontext
from pathlib import Path

import numpy as np
import pyopencl as cl

from . import __version__
from .extras import require
from .geometry.mesh_io import MESH_SUFFIXES
from .io import (
    Outputs,
    UsageError,
    load_checkpoint,
    output_folder,
    output_path,
    record,
    save_npz,
    write_npz,
    written_whole,
)
from .options import (
    MAX_FPS,
    MAX_SEED,
    MAX_STEPS_BETWEEN_FRAMES,
    ArgumentParser,
    HelpFormatter,
    parse_sets,
    parse_size,
    quiet_broken_pipe,
    scene_named,
    scene_params,
)
from .registry import scenes
from .run import Diverged, open_simulation, prepare_pictures, report, restore_checkpoint, run_steps
from .runtime import BuildError, DeviceError, Runtime, all_devices
from .scene import check_dt
from .stopping import StopWatch, Terminated
from .table import format_table

USAGE_ERROR, RUNTIME_ERROR, INTERRUPTED, TERMINATED = 2, 1, 130, 143
MESH_FORMATS = ", ".join(MESH_SUFFIXES)
"""The mesh formats as the help texts list them (every one ``--mesh`` takes)."""


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


def cmd_run(args) -> int:
    outputs = args.outputs = Outputs()  # main() says from it what an interrupted run wrote
    # {{{ everything that can be checked before the run
    if args.resume is not None:
        resume = load_checkpoint(args.resume, args.scene)
        if args.set or args.seed is not None:
            raise UsageError("--resume takes the scene, its parameters and the seed from the file; drop --set/--seed")
        if args.every:
            raise UsageError("--every cannot be combined with --resume (the history would start at the checkpoint)")
        scene, params, seed, sets = resume.scene, resume.params, resume.seed, {}
        args.dt = resume.dt if args.dt is None else args.dt
    else:
        resume = None
        if not args.scene:
            raise UsageError("run needs a scene (see `ugpcl list`) or --resume FILE")
        scene = scene_named(args.scene)
        sets = parse_sets(scene, args.set or [])
        params = scene_params(scene, sets)
        seed = 0 if args.seed is None else args.seed
    if args.steps < 0:
        raise UsageError(f"--steps must be >= 0, got {args.steps}")
    if not 0 <= seed <= MAX_SEED:
        raise UsageError(f"--seed must be in [0, {MAX_SEED}], got {seed}")
    if args.every is not None and args.every < 1:
        raise UsageError(f"--every must be >= 1, got {args.every}")
    if args.every and not scene.simulation.history:
        raise UsageError(f"--every: scene {scene.name} keeps no history arrays (--video-every sets a video's frames)")
    if args.video_every is not None and not 1 <= args.video_every <= MAX_STEPS_BETWEEN_FRAMES:
        raise UsageError(f"--video-every must be in [1, {MAX_STEPS_BETWEEN_FRAMES}], got {args.video_every}")
    if args.fps is not None and not 1 <= args.fps <= MAX_FPS:
        raise UsageError(f"--fps must be in [1, {MAX_FPS}], got {args.fps}")
    if args.video_every is not None and not (args.video or args.frames):
        raise UsageError("--video-every: give --video or --frames (it sets their frames)")
    if args.fps is not None and not args.video:
        raise UsageError("--fps: give --video (it sets the video's frame rate)")
    if args.checkpoint_every is not None and args.checkpoint_every < 1:
        raise UsageError(f"--checkpoint-every must be >= 1, got {args.checkpoint_every}")
    try:
        dt = check_dt(args.dt, scene.simulation.default_dt)
    except ValueError as err:
        raise UsageError(f"--{err}") from None
    if args.mesh and not hasattr(scene.simulation, "export_mesh"):
        raise UsageError(f"--mesh: scene {scene.name} makes no mesh")
    out = output_path(f"out/{scene.name}.npz" if args.out is None else args.out, "--out", (".npz",))
    if args.checkpoint is None and args.checkpoint_every:
        args.checkpoint = str(out.with_name(f"{out.stem}.checkpoint.npz"))
    checkpoint = output_path(args.checkpoint, "--checkpoint", (".npz",))
    png = output_path(args.png, "--png", (".png",))
    if args.video is not None and args.frames is not None:
        raise UsageError("--video and --frames: give one (a run records one sequence)")
    recording = output_path(args.video, "--video", (".mp4", ".webp")) or output_folder(args.frames, "--frames")
    if args.png or args.frames is not None or (args.video and args.video.lower().endswith(".webp")):
        what = "--png" if args.png else "--frames" if args.frames is not None else "--video (WebP)"
        require(what, "render", ("moderngl", "PIL"))
    if args.video and args.video.lower().endswith(".mp4"):
        require("--video (MP4)", "video")
    if args.mesh and args.mesh.lower().endswith(".glb"):
        require("--mesh (.glb)", "render", ("trimesh", "PIL"))
    mesh = output_path(args.mesh, "--mesh", MESH_SUFFIXES)
    size = parse_size(args.png_size)
    first_frame = recording / "frame-000000.png" if args.frames is not None else recording
    for path in (out, checkpoint, png, mesh, first_frame):  # leftovers of a killed run in these folders go
        outputs.target(path)
    # }}}
    warn_unused(params.ignored(sets))  # a --set that changes nothing is said, and the run goes on
    runtime = Runtime.shared(args.device)
    sim = open_simulation(scene, params, seed, runtime, announce=resume is None)
    if resume is not None:  # announced once restored: a checkpoint refused then is still one line
        restore_checkpoint(sim, resume)
        print(f"ugpcl: {scene.name} on {runtime.label}, resumed {args.resume} at step {sim.steps}", file=sys.stderr)

    def save_checkpoint(state: dict) -> None:
        write_npz(checkpoint, record(sim, state, dt))
        outputs.note(checkpoint, f"checkpoint {checkpoint} at step {sim.steps}")

    start = time.perf_counter()
    diverged = None
    try:
        checkpoints = (args.checkpoint_every, save_checkpoint) if args.checkpoint_every else None
        history = args.every if scene.simulation.history else None
        if recording:
            from .viewer.offscreen import renderer
            from .viewer.record import VIDEO_FPS, Recorder
        with Recorder(recording, fps=args.fps or VIDEO_FPS) if recording else nullcontext() as recorder:
            frames = None
            if recorder:
                render = renderer(scene, sim, size)

                def add_frame() -> None:
                    recorder.add(render())
                    if args.frames:  # each frame is in place as soon as it is added
                        outputs.note(recording, f"{recorder.frames} frames in {recording}")

                frames = (args.video_every or 1, add_frame)
            state = run_steps(sim, args.steps, dt, history, args.quiet, checkpoints, frames)
        if recorder:
            outputs.note(recording, f"{recording} ({recorder.frames} frames)")
            print(f"wrote {recording} ({recorder.frames} frames)")
    except Diverged as err:
        sets = " ".join(args.set or []) or "none (the scene's defaults)"
        diverged = f"{err}; parameters set: {sets}"
        if not args.keep_diverged:
            raise RuntimeError(f"{diverged}; {outputs.summary()} (--keep-diverged writes it anyway)") from None
        state = {**err.state, "diverged": np.bool_(True)}
    runtime.finish()
    seconds = time.perf_counter() - start
    # every file to a temporary name first, then all renamed in this order: an interrupt before the renames
    # leaves every earlier file as it was; a diverged state (--keep-diverged) is written as asked, without pictures
    with outputs:
        arrays = record(sim, state, dt)
        writer = save_npz(arrays, compress=args.compress)
        outputs.prepare("--out", out, writer, None if diverged else arrays, sim.may_be_infinite)
        if not diverged:
            prepare_pictures(outputs, sim, mesh, png, size)
        outputs.commit()
    took = f"{outputs.sizes[out]} bytes, {args.steps} steps in {seconds:.2f} s"
    print(f"wrote {out} ({took}): {', '.join(sorted(state))}")
    if diverged:
        print(f"ugpcl: error: {diverged}", file=sys.stderr)
        return RUNTIME_ERROR
    for key, value in sim.stats().items():
        print(f"  {key}: {value}")
    for path in (mesh, png):
        if path:
            print(f"wrote {path} ({outputs.sizes[path]} bytes)")
    short = sim.incomplete()
    if short:  # written as asked, and said: a result that falls short is never silent
        strict = args.strict or sim.strict
        print(f"ugpcl: {'error' if strict else 'warning'}: {scene.name}: {short}", file=sys.stderr)
        return RUNTIME_ERROR if strict else 0
    return 0


def warn_unused(lines) -> None:
    """Say each parameter given that the other settings leave unused (``Params.ignored``): one line each on stderr;
    the command goes on as asked."""
    for line in lines:
        print(f"ugpcl: warning: {line}", file=sys.stderr)


def cmd_sweep(args) -> int:
    require("ugpcl sweep", "sweep")
    if args.png:
        require("--png", "render", ("moderngl", "PIL"))
    from .sweep import INDEX, Tally, check_run_count, parse_grid, parse_seeds, plan, sweep

    scene = scene_named(args.scene)
    grid = parse_grid(scene, args.grid or [])
    sets = parse_sets(scene, args.set or [])
    for name in grid.keys() & sets.keys():
        raise UsageError(f"{name} is given by both --grid and --set")
    seeds = parse_seeds(args.seeds)
    check_run_count(grid, seeds)
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
    out = Path(args.out).absolute()  # made absolute here: a worker started in another folder writes under this one
    output_path(str(out / INDEX), "--out", (".csv",))
    common = {"steps": args.steps, "dt": dt, "png_size": parse_size(args.png_size), "device": args.device}
    jobs = plan(scene, grid, sets, seeds, out, args.png, mesh_suffix, **common)
    runs = {job.params_json: job.changed for job in jobs}  # one per grid point: its seeds share the parameters
    warn_unused(dict.fromkeys(line for changed in runs.values() for line in scene.params(**changed).ignored(changed)))
    args.outputs = Tally(out / INDEX)  # what a stopped sweep says it wrote
    tally = sweep(jobs, out, args.scheduler, args.device, args.quiet, args.outputs, args.no_worker_timeout)
    print(f"{out / INDEX}: {tally.ok} ok, {tally.failed} failed, {tally.skipped} finished before")
    return RUNTIME_ERROR if tally.failed else 0


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
    names = args.scene or list(benches)
    for name in names:
        if name not in benches:
            raise UsageError(f"unknown bench {name!r}; valid: {', '.join(benches)}")
    frames = {}  # the frames bench's own options: --scenes, and --all after a bench name (every scene's row)
    if args.scenes is not None or (args.all and "frames" in args.scene):
        if "frames" not in names:
            raise UsageError("--scenes: only the frames bench takes it (ugpcl bench frames --scenes NAME ...)")
        unknown = [s for s in args.scenes or () if s not in scenes()]
        if unknown:
            raise UsageError(f"--scenes: no scene {unknown[0]!r}; see ugpcl list")
        frames = {"scenes": args.scenes, "every": args.all}
    out = output_path(args.json, "--json", (".json",))
    runtime = Runtime.shared(args.device)
    date = time.strftime("%Y-%m-%d")
    records = []
    for name in names:
        bench = benches[name]
        rows = bench(runtime, args.size, **frames) if name == "frames" else bench(runtime, args.size)
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


def build_parser() -> argparse.ArgumentParser:
    fmt = HelpFormatter
    device = ArgumentParser(add_help=False)
    device.add_argument(
        "--device",
        default=None,
        metavar="NAME",
        help="OpenCL device: a substring of 'platform | device' such as pocl or nvidia (also UGPCL_DEVICE; "
        "unset: PYOPENCL_CTX, then the first GPU, then the first CPU)",
    )
    parser = ArgumentParser(prog="ugpcl", description=__doc__.splitlines()[0], formatter_class=fmt, allow_abbrev=False)
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
    p.add_argument("--compress", action="store_true", help="write the .npz compressed (smaller, slower to write)")
    p.add_argument("--png", default=None, help="also render the final state to this PNG (offscreen, EGL)")
    p.add_argument("--png-size", default="800x600", help="PNG size WxH (also of --video and --frames frames)")
    p.add_argument(
        "--video",
        default=None,
        metavar="FILE.mp4|.webp",
        help="record the run offscreen to an MP4 or a looping animated WebP: the first state, then every "
        "--video-every K steps (default 1), at --fps frames a second (default 30)",
    )
    p.add_argument("--video-every", type=int, default=None, metavar="K", help="a frame every K steps (default 1)")
    p.add_argument("--fps", type=int, default=None, help="frames per second of the --video (default 30)")
    p.add_argument(
        "--frames", default=None, metavar="DIR", help="as --video, to DIR/frame-000000.png, frame-000001.png ..."
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress bar (on a terminal) or progress lines every few seconds (otherwise) on stderr",
    )
    p.add_argument("--mesh", default=None, help=f"export the scene's geometry ({MESH_FORMATS}) where it makes one")
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
        "--strict",
        action="store_true",
        help="exit 1 when the scene's result falls short of what was asked (ear clipping that leaves input area "
        "uncovered); without it that is a one-line warning on stderr",
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
    p.add_argument(
        "--mesh", default=None, metavar="EXT", help=f"also export each run's geometry as RUN.EXT ({MESH_FORMATS})"
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="a running dask scheduler (tcp://host:port) to run on (default: a local cluster, one worker per GPU "
        "or two on a CPU device)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar or progress lines on stderr")
    p.add_argument(
        "--no-worker-timeout",
        action="store_true",
        help="end the sweep (exit 1) when no worker has been alive for 30 s; without it the sweep says so and waits",
    )

    p = command("bench", "time scenes and print throughput tables", cmd_bench, [device])
    p.add_argument("scene", nargs="*", help="copy, peak, launch or chapter stems (none: all)")
    p.add_argument("--all", action="store_true", help="every bench; after frames: every scene at its defaults too")
    p.add_argument("--scenes", nargs="+", default=None, metavar="NAME", help="frames bench: only these scenes")
    p.add_argument("--size", type=int, nargs="+", default=None, help="problem sizes (default: the chapter's)")
    p.add_argument("--json", default=None, metavar="FILE", help="also write every figure of the tables to FILE.json")
    return parser


def written(args) -> str:
    """What a stopped command had written: ``nothing was written``, or what its Outputs committed."""
    outputs = getattr(args, "outputs", None)
    return outputs.summary() if outputs else "nothing was written"


def stopped_line(signum: int, args) -> str:
    """The last line of a command ended by Ctrl-C or SIGTERM."""
    how = "interrupted" if signum == signal.SIGINT else "terminated (SIGTERM)"
    return f"ugpcl: {how}; {written(args)}"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    # Ctrl-C and SIGTERM end a run within stopping.GRACE seconds, old outputs untouched (only from the main thread,
    # where signals arrive; the caller's handlers are put back afterwards)
    in_main = threading.current_thread() is threading.main_thread()
    with StopWatch(lambda signum: stopped_line(signum, args)) if in_main else nullcontext() as watch:
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
        except (KeyboardInterrupt, Terminated) as err:
            signum = signal.SIGINT if isinstance(err, KeyboardInterrupt) else signal.SIGTERM
            print(stopped_line(signum, args), file=sys.stderr, flush=True)
            if watch:
                watch.reported()
            return INTERRUPTED if signum == signal.SIGINT else TERMINATED


if __name__ == "__main__":
    sys.exit(main())


def view(argv: list[str] | None = None) -> int:
    """``ugpcl-view``: the window, when the viewer extra is installed; else one line saying how to get it (exit 2)."""
    try:
        require("ugpcl-view", "viewer")
    except UsageError as err:
        print(f"ugpcl-view: error: {err}", file=sys.stderr)
        return USAGE_ERROR
    from .viewer.app import main as view_main

    return view_main(argv)
