"""A headless run of a scene, below the command line: open the simulation (its buffers checked against the device),
go on from a checkpoint, step it with the device queue kept a few steps ahead and the state watched for NaN/inf,
show progress, and write its mesh and picture. ``ugpcl run``, each ``ugpcl sweep`` task, the viewer (its watch)
and the chapter pages' animations share it.
"""

from __future__ import annotations

import shutil
import sys
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyopencl as cl

from . import resources
from .io import Checkpoint, Outputs, UsageError, non_finite
from .runtime import Runtime
from .scene import ParamError, Params, Scene, Simulation

CHECK_SECONDS = 2.0
"""How often a run reads its state back to look for NaN/inf (also at every --every snapshot and at the end)."""
STEPS_IN_FLIGHT = 4
"""Steps ``ugpcl run`` lets the device queue hold before it waits for the oldest: the progress bar counts
finished steps, and the host never runs far ahead of the device."""
PROGRESS_LINE_SECONDS = 5.0
"""How often a run whose stderr is not a terminal prints a progress line."""


class Diverged(RuntimeError):
    """The simulation produced NaN or inf: one line naming the arrays, the steps and the parameters that were set."""

    def __init__(self, first: int, last: int, arrays: list[str], state: dict):
        steps = f"step {last}" if first == last else f"steps {first} and {last}"
        super().__init__(f"diverged between {steps}: {', '.join(arrays)} hold NaN or inf")
        self.state = state


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


class ProgressLines:
    """Signs of life when stderr is not a terminal (a log file, CI, a batch job): one line every ``interval``
    seconds, ``ugpcl: boids step 120/600 (20%), 31.2 steps/s, about 15 s left``. Same use as a tqdm bar."""

    def __init__(self, label: str, total: int, interval: float, unit: str = "step"):
        self.label, self.total, self.interval, self.unit = label, total, interval, unit
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
                f"ugpcl: {self.label} {self.unit} {self.done}/{self.total} ({100 * self.done // self.total}%), "
                f"{rate:.3g} {self.unit}s/s, about {left:.0f} s left",
                file=sys.stderr,
                flush=True,
            )

    def __enter__(self) -> ProgressLines:
        return self

    def __exit__(self, *exc) -> None:
        pass


def progress(label: str, total: int, quiet: bool, unit: str = "step"):
    """A progress bar on a terminal; a line every PROGRESS_LINE_SECONDS otherwise; nothing with ``quiet``. ``unit``:
    what is counted (steps of a run, runs of a sweep)."""
    if quiet or not sys.stderr.isatty():
        return ProgressLines(label, total, float("inf") if quiet else PROGRESS_LINE_SECONDS, unit)
    from tqdm import tqdm

    # a pseudo-terminal may report a 0 x 0 screen (script, some CI runners): tqdm would then draw nothing
    columns, lines = shutil.get_terminal_size()
    return tqdm(total=total, unit=unit, file=sys.stderr, mininterval=0.25, ncols=min(columns, 100), nrows=lines)


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
    with progress(sim.scene.name if sim.scene else type(sim).__name__, steps, quiet) as bar:
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
                bar.update()
        while in_flight:
            in_flight.popleft().wait()
            bar.update()
    out = dict(watch.check())
    if every:
        for key in sim.history:
            out[f"{key}_history"] = np.stack([f[key] for f in frames])
        out["time"] = np.asarray(times, np.float32)
    return out


def open_simulation(scene: Scene, params: Params, seed: int, runtime: Runtime, announce: bool = False) -> Simulation:
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


def restore_checkpoint(sim: Simulation, checkpoint: Checkpoint) -> None:
    """Put ``sim`` where a checkpoint (``io.load_checkpoint``) left it: its state, step count and clock, after
    checking each array against the state the scene holds for these parameters (name, dtype, shape, finite)."""
    fresh = sim.state()
    for key, value in fresh.items():
        expected = np.asarray(value)
        found = checkpoint.arrays.get(key)
        if found is None:
            raise UsageError(f"--resume {checkpoint.path}: no array {key!r} (scene {sim.scene.name} keeps it)")
        if (found.dtype, found.shape) != (expected.dtype, expected.shape):
            raise UsageError(
                f"--resume {checkpoint.path}: array {key} is {found.dtype} of shape {found.shape}; "
                f"its parameters make {expected.dtype} of shape {expected.shape}"
            )
    if bad := non_finite({key: checkpoint.arrays[key] for key in fresh}, sim.may_be_infinite):
        raise UsageError(f"--resume {checkpoint.path}: {', '.join(bad)} hold NaN or inf")
    sim.restore(checkpoint.arrays)
    sim.steps, sim.time = checkpoint.steps, checkpoint.sim_time


def prepare_pictures(outputs: Outputs, sim: Simulation, mesh: Path | None, png: Path | None, size) -> None:
    """The mesh and the PNG of a finished run, written to ``outputs``' temporary files (committed with the rest)."""
    if mesh:
        outputs.prepare("--mesh", mesh, sim.export_mesh)
    if png:
        from .viewer.offscreen import render_png

        outputs.prepare("--png", png, lambda path: render_png(sim.scene, sim, path, size))


def write_pictures(sim: Simulation, mesh: Path | None, png: Path | None, size: tuple[int, int]) -> None:
    """The mesh and the PNG of a finished run, each written whole, both or neither."""
    with Outputs() as outputs:
        prepare_pictures(outputs, sim, mesh, png, size)
        outputs.commit()


def report(prog: str, err: BaseException) -> str:
    """One line for an error that ends a run: its message's first line, with the exception's kind where the
    message alone would not say what failed."""
    text = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
    if isinstance(err, cl.Error | MemoryError | ArithmeticError):
        text = f"{type(err).__name__}: {text}"
    return f"{prog}: error: {text}"
