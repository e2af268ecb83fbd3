"""``ugpcl sweep``: the runs of a parameter grid times a list of seeds as Dask tasks, on a local cluster or on one
started elsewhere (``dask scheduler`` + ``dask worker ADDRESS``).

Each task is one ``ugpcl run``: the same simulation, the same .npz (``io.record``), written whole. The driver keeps
``DIR/index.csv``, one row per run (its parameters, seed, device, status, error, wall time, summary stats),
rewritten whole after every result: a sweep stopped at any point (Ctrl-C, a lost worker, a lost driver) keeps every
finished run, and running it again computes only the runs that are not finished.
"""

from __future__ import annotations

import csv
import itertools
import logging
import math
import os
import re
import socket
import sys
import time
import typing
from dataclasses import dataclass, field
from pathlib import Path

from .io import UsageError, record, write_npz, written_whole
from .options import MAX_SEED, scene_params
from .run import open_simulation, progress, report, run_steps, write_pictures
from .runtime import DeviceError, Runtime, choose_device
from .scene import Scene

INDEX = "index.csv"
FIXED_COLUMNS = ["run", "scene", "seed", "steps", "status", "error", "device", "worker", "wall_s", "finished"]
"""Columns of index.csv before the parameters that were set (grid and --set) and after them the stats, then the
full parameter set as JSON (what decides whether a finished run still matches the sweep)."""


# {{{ what to run


def parse_grid(scene: Scene, items: list[str]) -> dict[str, list]:
    """``--grid name=v1,v2`` items as {name: [values]}, each value converted and range-checked by the field.
    Tuple fields separate their values with ``/``: ``--grid wall_size=8,8,8/16,16,16``."""
    params = scene.simulation.Params
    hints = typing.get_type_hints(params)
    grid: dict[str, list] = {}
    for item in items:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not text.strip():
            raise UsageError(f"--grid expects name=value,value,..., got {item!r}")
        if name in grid:
            raise UsageError(f"--grid names {name} twice")
        is_tuple = name in hints and typing.get_origin(hints[name]) is tuple
        texts = text.split("/" if is_tuple else ",")
        try:
            grid[name] = [params.parse(name, t.strip()) for t in texts]
        except ValueError as err:
            raise UsageError(f"--grid {err}") from None
        if len(set(grid[name])) < len(grid[name]):
            raise UsageError(f"--grid {name} repeats a value")
    return grid


MAX_RUNS = 100_000
"""Most runs one sweep takes: its index lists every run and is rewritten after each result."""


def parse_seeds(text: str) -> list[int]:
    """``0-9``, ``3`` or ``1,4,7-9`` as a list of distinct seeds in [0, MAX_SEED]. The ranges are counted and checked
    for overlaps before any list is made, so ``0-100000000`` is refused at once."""
    ranges: list[tuple[int, int]] = []
    for part in text.split(","):
        match = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", part)
        if not match:
            raise UsageError(f"--seeds expects seeds and ranges like 0-9 or 1,4,7-9, got {text!r}")
        first, last = int(match[1]), int(match[2] or match[1])
        if first > last or last > MAX_SEED:
            raise UsageError(f"--seeds {part.strip()}: a range runs upward within [0, {MAX_SEED}]")
        ranges.append((first, last))
    count = sum(last - first + 1 for first, last in ranges)
    if count > MAX_RUNS:
        raise UsageError(f"--seeds {text}: {count} seeds, over the {MAX_RUNS} runs a sweep takes")
    ordered = sorted(ranges)
    if any(later[0] <= earlier[1] for earlier, later in itertools.pairwise(ordered)):
        raise UsageError(f"--seeds {text}: a seed appears twice")
    return [seed for first, last in ranges for seed in range(first, last + 1)]


def check_run_count(grid: dict[str, list], seeds: list[int]) -> None:
    """UsageError when the grid times the seeds is more than MAX_RUNS, before any run is planned."""
    runs = len(seeds) * math.prod(len(values) for values in grid.values())
    if runs > MAX_RUNS:
        raise UsageError(f"--grid and --seeds make {runs} runs, over the {MAX_RUNS} a sweep takes")


@dataclass(frozen=True)
class Job:
    """One run of a sweep: everything a worker needs (picklable), and the files it writes."""

    scene: str
    name: str
    changed: dict
    """The parameters set for this run (--set, then this run's grid values), as Params field values."""
    seed: int
    steps: int
    dt: float
    params_json: str
    npz: Path
    png: Path | None = None
    png_size: tuple[int, int] = (800, 600)
    mesh: Path | None = None
    device: str | None = None
    outputs: tuple[Path, ...] = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "outputs", tuple(p for p in (self.npz, self.png, self.mesh) if p))


def run_name(changed: dict, seed: int) -> str:
    """A file stem naming a run by its grid values and seed: ``max_speed=2.0_seed=0``. Characters a file name
    should not hold become ``-``."""
    parts = [f"{k}={','.join(map(str, v)) if isinstance(v, tuple) else v}" for k, v in changed.items()]
    return re.sub(r"[^\w.,=+-]", "-", "_".join([*parts, f"seed={seed}"]))


def plan(
    scene: Scene,
    grid: dict[str, list],
    sets: dict,
    seeds: list[int],
    out: Path,
    png: bool = False,
    mesh_suffix: str | None = None,
    **common,
) -> list[Job]:
    """Every combination of grid values and seeds as a Job (``common``: steps, dt, png_size, device); UsageError
    when one of them fails the Params checks (a cross-field rule), before anything runs."""
    jobs = []
    for values in itertools.product(*grid.values()):
        changed = {**sets, **dict(zip(grid, values, strict=True))}
        params = scene_params(scene, changed)
        for seed in seeds:
            name = run_name(dict(zip(grid, values, strict=True)), seed)
            jobs.append(
                Job(
                    scene=scene.name,
                    name=name,
                    changed=changed,
                    seed=seed,
                    params_json=params.to_json(dt=common["dt"]),
                    npz=out / f"{name}.npz",
                    png=out / f"{name}.png" if png else None,
                    mesh=out / f"{name}{mesh_suffix}" if mesh_suffix else None,
                    **common,
                )
            )
    if len({job.name for job in jobs}) < len(jobs):
        raise UsageError(
            "--grid: two runs would write the same files (values that differ only in characters "
            "a file name cannot hold)"
        )
    return jobs


# }}}

# {{{ on a worker


def run_job(job: Job) -> dict:
    """Run one job on this worker and return its index row; a failure becomes a row with the error's line
    (``run.report``) rather than an exception, so that it does not stop the other tasks."""
    from .registry import get

    start = time.perf_counter()
    row = {"run": job.name, "scene": job.scene, "seed": job.seed, "steps": job.steps, "worker": _worker_name()}
    try:
        runtime = Runtime.shared(job.device)  # one per device and worker process: programs built once
        row["device"] = runtime.label
        scene = get(job.scene)
        sim = open_simulation(scene, scene.params(**job.changed), job.seed, runtime)
        state = run_steps(sim, job.steps, job.dt, quiet=True)
        runtime.finish()
        write_npz(job.npz, record(sim, state, job.dt))
        write_pictures(sim, job.mesh, job.png, job.png_size)
        row.update(status="ok", error="", **{f"stat:{k}": v for k, v in sim.stats().items()})
    except Exception as err:  # noqa: BLE001 - any failure of one run is that run's result
        row.update(status="failed", error=report(job.name, err))
    row.update(wall_s=round(time.perf_counter() - start, 4), finished=time.strftime("%Y-%m-%dT%H:%M:%S"))
    return row


def _worker_name() -> str:
    from distributed import get_worker

    try:
        return str(get_worker().name)
    except ValueError:  # not inside a worker (run_job called directly)
        return ""


# }}}

# {{{ the driver


def local_cluster_size(device: str | None) -> tuple[int, int]:
    """(workers, threads per worker) for a LocalCluster on this machine. A GPU runs one simulation at a time well
    and the host side of a run is one thread: one worker per GPU of its platform. A CPU OpenCL device (PoCL) spreads
    every kernel over all cores already, so more workers would only fight over them: two single-threaded workers,
    so that one run's host side (program build, read-back, file writes) overlaps the other's kernels."""
    try:
        chosen, _ = choose_device(device)
    except DeviceError as err:
        raise UsageError(str(err)) from None
    import pyopencl as cl

    if chosen.type & cl.device_type.GPU:
        same = [d for d in chosen.platform.get_devices() if d.name == chosen.name]
        return len(same), 1
    return min(2, os.cpu_count() or 1), 1


def read_index(path: Path) -> dict[str, dict]:
    """The rows of an earlier sweep's index by run name (none when there is no index yet); UsageError naming the file
    when it is not one (damaged, truncated, another file)."""
    if not path.exists():
        return {}
    fix = "move it away or give another --out"
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            columns = reader.fieldnames or []
            missing = [c for c in ("run", "status", "steps", "params") if c not in columns]
            if missing:
                raise UsageError(f"{path}: not a sweep index (no {', '.join(missing)} column); {fix}")
            rows = {}
            for row in reader:
                if None in row or None in row.values():  # more or fewer cells than the header has columns
                    raise UsageError(f"{path}: line {reader.line_num} does not match its header; {fix}")
                rows[row["run"]] = row
            return rows
    except (csv.Error, UnicodeDecodeError) as err:
        raise UsageError(f"{path}: not a sweep index ({err}); {fix}") from None
    except OSError as err:
        raise UsageError(f"{path}: cannot read it ({err.strerror}); {fix}") from None


def finished(job: Job, row: dict | None) -> bool:
    """The index says the run succeeded with these parameters and steps, and all its outputs are there."""
    return (
        row is not None
        and row.get("status") == "ok"
        and row.get("params") == job.params_json
        and row.get("steps") == str(job.steps)
        and all(p.exists() for p in job.outputs)
    )


def write_index(path: Path, jobs: list[Job], rows: dict[str, dict]) -> None:
    """index.csv in the order of the jobs, written whole; runs without a result yet are ``pending``."""
    params = list(dict.fromkeys(k for job in jobs for k in job.changed))
    table = []
    for job in jobs:
        row = rows.get(job.name) or {"run": job.name, "scene": job.scene, "seed": job.seed, "steps": job.steps}
        table.append({"status": "pending", **row, **job.changed, "params": job.params_json})
    stats = list(dict.fromkeys(k for row in table for k in row if k.startswith("stat:")))
    columns = FIXED_COLUMNS[:2] + params + FIXED_COLUMNS[2:] + stats + ["params"]
    with written_whole(path) as partial, open(partial, "w", newline="") as f:
        writer = csv.DictWriter(f, columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(table)


HANDSHAKE_SECONDS = 5.0
"""How long a --scheduler address has to greet a new connection: a Dask scheduler does it at once."""
WORKERS_SECONDS = 60.0
"""How long a sweep on a --scheduler waits for its first worker."""


def check_scheduler(address: str) -> None:
    """UsageError unless ``address`` is a tcp:// Dask scheduler that answers. Dask's own client waits forever on a
    listener that accepts and never speaks, so the greeting is read here first, with a timeout."""
    scheme, _, rest = address.rpartition("://")
    if scheme not in ("", "tcp"):
        why = "TLS needs certificates that ugpcl sweep does not take" if scheme == "tls" else f"{scheme}:// is not"
        raise UsageError(f"--scheduler {address}: {why}; give a tcp://HOST:PORT scheduler")
    host, _, port = rest.rpartition(":")
    if not host or not port.isdigit():
        raise UsageError(f"--scheduler {address}: expected tcp://HOST:PORT")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=HANDSHAKE_SECONDS) as conn:
            conn.settimeout(HANDSHAKE_SECONDS)
            greeted = conn.recv(1)
    except TimeoutError:
        greeted = b""
    except OSError as err:
        raise UsageError(f"--scheduler {address}: cannot connect ({err.strerror or err})") from None
    if not greeted:
        raise UsageError(f"--scheduler {address}: not a Dask scheduler (no greeting within {HANDSHAKE_SECONDS:g} s)")


@dataclass
class Tally:
    """How a sweep stands: the runs finished before it, ok and failed in it; what a stopped sweep says it wrote."""

    index: Path
    skipped: int = 0
    ok: int = 0
    failed: int = 0

    def summary(self) -> str:
        return f"{self.ok + self.failed} runs finished ({self.failed} failed), {self.skipped} before; see {self.index}"


NO_WORKER_SECONDS = 30.0
"""A sweep with no live worker this long says so (and, with --no-worker-timeout, ends)."""


class Idle:
    """Watches a cluster that has stopped finishing runs: after NO_WORKER_SECONDS without a live worker it says so
    once on stderr (one line) and, with ``give_up``, ends the sweep; a worker that joins again starts it afresh."""

    def __init__(self, client, give_up: bool):
        self.client, self.give_up = client, give_up
        self.since: float | None = None
        self.said = False

    def check(self, waiting: int) -> None:
        if self.client.scheduler_info().get("workers"):
            self.since, self.said = None, False
            return
        now = time.monotonic()
        self.since = self.since or now
        if now - self.since < NO_WORKER_SECONDS or self.said:
            return
        self.said = True
        if self.give_up:
            left = f"no live worker for {NO_WORKER_SECONDS:g} s with {waiting} runs left"
            raise RuntimeError(f"{left} (--no-worker-timeout)")
        print(
            f"ugpcl: sweep: no live worker for {NO_WORKER_SECONDS:g} s, {waiting} runs waiting; start a worker, or "
            "Ctrl-C (the index keeps what finished)",
            file=sys.stderr,
            flush=True,
        )


def _result(future, idle: Idle, waiting: int):
    """A finished future's result: its data may sit on a worker that has just died, and then the run is done again
    somewhere, so the wait is in steps during which ``idle`` looks for live workers."""
    from distributed import TimeoutError as Timeout

    while True:
        try:
            return future.result(timeout=1.0)
        except Timeout:
            idle.check(waiting)


def _as_they_finish(futures, idle: Idle, waiting: int):
    """The futures as they finish; between them, about once a second, ``idle`` looks for live workers."""
    while not futures.is_empty():
        batch = futures.next_batch(block=False)
        if not batch:
            idle.check(waiting)
            time.sleep(1.0 if idle.since else 0.05)
            continue
        for future in batch:
            waiting -= 1
            yield future


def sweep(
    jobs: list[Job],
    out: Path,
    scheduler: str | None,
    device: str | None,
    quiet: bool,
    tally: Tally | None = None,
    no_worker_timeout: bool = False,
) -> Tally:
    """Run the jobs not finished yet on a Dask cluster (``scheduler``'s, or a LocalCluster made for this sweep),
    keeping ``out/index.csv`` current; ``tally`` (made here when not given) counts the runs skipped, ok and failed."""
    from distributed import Client, LocalCluster, as_completed

    index = out / INDEX
    tally = tally or Tally(index)
    earlier = read_index(index)
    if scheduler:
        check_scheduler(scheduler)
    # announced once the index and the scheduler are known good: a bad one is the only line
    print(f"ugpcl: sweep {jobs[0].scene}: {len(jobs)} runs on {scheduler or 'a local cluster'}", file=sys.stderr)
    rows = {job.name: earlier[job.name] for job in jobs if finished(job, earlier.get(job.name))}
    todo = [job for job in jobs if job.name not in rows]
    tally.skipped = len(rows)
    write_index(index, jobs, rows)
    if not todo:
        return tally
    logging.getLogger("distributed").setLevel(logging.CRITICAL)  # a lost worker is a failed row, not log lines
    if scheduler:
        cluster, client = None, Client(scheduler, timeout="20s")
        try:
            client.wait_for_workers(1, timeout=WORKERS_SECONDS)
        except TimeoutError:
            client.close()
            raise RuntimeError(f"--scheduler {scheduler}: no worker joined within {WORKERS_SECONDS:g} s") from None
    else:
        workers, threads = local_cluster_size(device)
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=threads, dashboard_address=":0", silence_logs=logging.CRITICAL
        )
        client = Client(cluster)
    try:
        # keys of this sweep's own: a cluster that still holds an earlier sweep's results must run the job again
        by_key = {f"ugpcl-sweep-{job.name}-{time.time_ns()}": job for job in todo}
        futures = as_completed(client.map(run_job, list(by_key.values()), key=list(by_key)))
        idle = Idle(client, no_worker_timeout)
        with progress(f"sweep {todo[0].scene}", len(todo), quiet, unit="run") as bar:
            for future in _as_they_finish(futures, idle, len(todo) - tally.ok - tally.failed):
                job = by_key[future.key]
                try:
                    row = _result(future, idle, len(todo) - tally.ok - tally.failed)
                except Exception as err:  # noqa: BLE001 - the task itself failed (a worker lost too often)
                    row = {"run": job.name, "scene": job.scene, "seed": job.seed, "steps": job.steps}
                    row.update(
                        status="failed", error=report(job.name, err), finished=time.strftime("%Y-%m-%dT%H:%M:%S")
                    )
                # recorded: let the cluster forget it, or the loss of the worker holding it would run it again
                future.release()
                rows[job.name] = row
                write_index(index, jobs, rows)
                setattr(tally, row["status"], getattr(tally, row["status"]) + 1)
                if row["status"] != "ok":
                    print(row["error"], file=sys.stderr, flush=True)
                bar.update()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return tally


# }}}
