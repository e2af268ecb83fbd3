"""``ugpcl list | info | params | run | bench``: the headless front end.

Results go to stdout, logs and errors to stderr. Exit codes: 0 ok, 1 runtime failure (no device, build
error), 2 bad usage (unknown scene, bad parameter).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from . import __version__
from .runtime import BuildError, DeviceError, Runtime, all_devices
from .scene import Scene, Simulation, check_dt
from .scenes import get, modules, scenes

USAGE_ERROR, RUNTIME_ERROR = 2, 1


class UsageError(Exception):
    """Bad input from the command line: printed as one line, exit 2."""


# {{{ tables


def format_table(rows: list[dict], columns: list[str] | None = None) -> str:
    """Plain fixed-width table; floats get 4 significant digits (or engineering form when large)."""
    if not rows:
        return "(no rows)"
    columns = columns or list(dict.fromkeys(k for row in rows for k in row))

    def cell(v) -> str:
        if isinstance(v, float):
            return f"{v:.3e}" if abs(v) >= 1e5 or (v != 0 and abs(v) < 1e-3) else f"{v:.4g}"
        return str(v)

    text = [[cell(row.get(c, "")) for c in columns] for row in rows]
    widths = [max(len(c), *(len(t[i]) for t in text)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(t.rjust(w) for t, w in zip(r, widths, strict=True)) for r in text]
    return "\n".join(lines)


# }}}

# {{{ commands


def cmd_list(args) -> int:
    for name, scene in scenes().items():
        print(f"{name:32s} {scene.summary}")
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
    runtime = Runtime()
    print("\nchosen:")
    facts = runtime.describe()
    for key, value in facts.items():
        print(f"  {key:22s} {value}")
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
                {"limit": "compute units (SMs)", "book (cs_5_0)": "-", "device": d.max_compute_units},
            ]
        )
    )
    print("\nHLSL compute shader -> OpenCL (ch.2):")
    for hlsl, ocl in HLSL_TO_OPENCL:
        print(f"  {hlsl:46s} {ocl}")
    return 0


def cmd_params(args) -> int:
    scene = get(args.scene)
    rows = scene.simulation.Params.table()
    for row in rows:
        if row["name"] in scene.defaults:
            row["default"] = str(scene.defaults[row["name"]])
    print(format_table(rows))
    return 0


def parse_sets(scene: Scene, pairs: list[str]) -> dict:
    params = scene.simulation.Params
    out = {}
    for pair in pairs:
        name, sep, text = pair.partition("=")
        if not sep:
            raise UsageError(f"--set expects name=value, got {pair!r}")
        out[name.strip()] = params.parse(name.strip(), text)
    return out


def _progress(total: int):
    from tqdm import tqdm

    return tqdm(total=total, unit="step", file=sys.stderr, disable=None, leave=False, mininterval=0.5)


def run_steps(sim: Simulation, steps: int, dt: float, every: int | None) -> dict[str, np.ndarray]:
    """Step ``sim`` and return the final state plus, with ``every``, stacked ``<name>_history`` and ``time``."""
    frames, times = [], []

    def snapshot():
        state = sim.state()
        frames.append({k: state[k] for k in sim.history})
        times.append(sim.time)

    if every:
        snapshot()
    with _progress(steps) as bar:
        for i in range(1, steps + 1):
            sim.step(dt)
            if every and i % every == 0:
                snapshot()
            bar.update()
    out = dict(sim.state())
    if every:
        for key in sim.history:
            out[f"{key}_history"] = np.stack([f[key] for f in frames])
        out["time"] = np.asarray(times, np.float32)
    return out


def cmd_run(args) -> int:
    scene = get(args.scene)
    overrides = parse_sets(scene, args.set or [])
    params = scene.params(**overrides)
    if args.steps < 0:
        raise UsageError(f"--steps must be >= 0, got {args.steps}")
    if args.every is not None and args.every < 1:
        raise UsageError(f"--every must be >= 1, got {args.every}")
    if args.every and not scene.simulation.history:
        raise UsageError(f"--every: scene {scene.name} keeps no history arrays")
    dt = check_dt(args.dt, scene.simulation.default_dt)
    if args.mesh and not hasattr(scene.simulation, "export_mesh"):
        raise UsageError(f"--mesh: scene {scene.name} makes no mesh")
    runtime = Runtime()
    print(f"ugpcl: {scene.name} on {runtime.label}", file=sys.stderr)
    sim = scene.simulation(runtime, params, args.seed)
    start = time.perf_counter()
    state = run_steps(sim, args.steps, dt, args.every)
    runtime.finish()
    seconds = time.perf_counter() - start
    out = Path(args.out or f"out/{scene.name}.npz")
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez(
        out,
        **state,
        params=np.array(params.to_json(dt=dt)),
        scene=np.array(scene.name),
        seed=np.int64(args.seed),
        steps=np.int64(args.steps),
        device=np.array(runtime.label),
        ugpcl_version=np.array(__version__),
    )
    print(f"wrote {out} ({args.steps} steps in {seconds:.2f} s): {', '.join(sorted(state))}")
    for key, value in sim.stats().items():
        print(f"  {key}: {value}")
    if args.mesh:
        sim.export_mesh(args.mesh)
        print(f"wrote {args.mesh}")
    if args.png:
        from ugpcl.viewer.offscreen import render_png

        size = _parse_size(args.png_size)
        render_png(scene, sim, args.png, size)
        print(f"wrote {args.png}")
    return 0


def _parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        if not (16 <= w <= 8192 and 16 <= h <= 8192):
            raise ValueError
    except ValueError:
        raise UsageError(f"--png-size must be WxH with 16..8192 each, got {text!r}") from None
    return w, h


def cmd_bench(args) -> int:
    names = list(modules()) if args.all or not args.scene else args.scene
    for name in names:
        if name not in modules():
            stems = [n for n, m in modules().items() if hasattr(m, "bench")]
            raise UsageError(f"unknown bench {name!r}; valid: {', '.join(stems)}")
    runtime = Runtime()
    date = time.strftime("%Y-%m-%d")
    for name in names:
        module = modules()[name]
        if not hasattr(module, "bench"):
            continue
        rows = module.bench(runtime, args.size)
        print(f"\n## {name}  ({runtime.label}, {date})")
        print(" ".join(module.bench.__doc__.split()))
        print(format_table(rows))
        sys.stdout.flush()
    return 0


# }}}


def build_parser() -> argparse.ArgumentParser:
    fmt = argparse.ArgumentDefaultsHelpFormatter
    parser = argparse.ArgumentParser(
        prog="ugpcl", description=__doc__.splitlines()[0], formatter_class=fmt, allow_abbrev=False
    )
    parser.add_argument("--version", action="version", version=f"ugpcl {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="scenes and what they show", formatter_class=fmt, allow_abbrev=False).set_defaults(
        func=cmd_list
    )
    sub.add_parser(
        "info",
        help="OpenCL devices, the chosen one and why, HLSL-to-OpenCL mapping",
        formatter_class=fmt,
        allow_abbrev=False,
    ).set_defaults(func=cmd_info)
    p = sub.add_parser(
        "params", help="a scene's parameters: default, range, meaning", formatter_class=fmt, allow_abbrev=False
    )
    p.add_argument("scene")
    p.set_defaults(func=cmd_params)

    p = sub.add_parser(
        "run", help="run a scene headless and write its state to .npz", formatter_class=fmt, allow_abbrev=False
    )
    p.add_argument("scene")
    p.add_argument("--steps", type=int, default=300, help="simulation steps")
    p.add_argument("--seed", type=int, default=0, help="random seed (same seed + device = same result)")
    p.add_argument("--dt", type=float, default=None, help="time step in seconds (default: the scene's)")
    p.add_argument(
        "--set", action="extend", nargs="+", metavar="NAME=VALUE", help="override parameters (see `ugpcl params`)"
    )
    p.add_argument("--every", type=int, default=None, metavar="K", help="also keep every K-th state as *_history")
    p.add_argument("--out", default=None, help="output .npz (default: out/SCENE.npz)")
    p.add_argument("--png", default=None, help="also render the final state to this PNG (offscreen, EGL)")
    p.add_argument("--png-size", default="800x600", help="PNG size WxH")
    p.add_argument("--mesh", default=None, help="export the scene's geometry (.obj/.ply) where it makes one")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("bench", help="time scenes and print throughput tables", formatter_class=fmt, allow_abbrev=False)
    p.add_argument("scene", nargs="*", help="chapter stems (default: all)")
    p.add_argument("--all", action="store_true", help="every chapter that has a bench")
    p.add_argument("--size", type=int, nargs="+", default=None, help="problem sizes (default: the chapter's)")
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (UsageError, ValueError) as err:
        print(f"ugpcl: error: {err}", file=sys.stderr)
        return USAGE_ERROR
    except (DeviceError, BuildError) as err:
        print(f"ugpcl: {err}", file=sys.stderr)
        return RUNTIME_ERROR


if __name__ == "__main__":
    sys.exit(main())
