"""The device probes behind `ugpcl bench`: LaunchProbe's result, FmaProbe's arithmetic (so its flop count is real
work), the measured limits and the share columns built from them."""

from __future__ import annotations

import importlib

import numpy as np
import pyopencl as cl
import pytest

from ugpcl.bench.device import DeviceLimits, copy_rate, fp32_rate, read_back_rate, with_shares


def fma_probe_reference(n: int, rounds: int, a: float, b: float, first: int = 0) -> np.ndarray:
    """FmaProbe in float64 for global ids first .. first + n - 1: 8 chains x = a x + b per lane, rounds x 16 times,
    then summed."""
    i = np.arange(first, first + n, dtype=np.float64)[:, None]
    x0 = np.float32(1e-9) * (i + np.arange(4))
    chains = [x0 + c for c in (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7)]
    steps = rounds * 16
    out = sum((a**steps) * x + b * (1 - a**steps) / (1 - a) for x in chains)  # the closed form of the recurrence
    return out.sum(axis=1)


def run_probes(runtime, n: int = 64, rounds: int = 2) -> tuple[np.ndarray, np.ndarray]:
    program = runtime.program("probes")
    a, b = runtime.to_device(np.arange(n, dtype=np.float32)), runtime.to_device(np.ones(n, np.float32))
    out = runtime.zeros(n, np.float32)
    program.kernel("LaunchProbe")((n,), None, a.data, b.data, out.data, np.int32(n), np.float32(2.0), np.float32(0.5),
                                  np.int32(0))  # fmt: skip
    launch = out.get()
    fma = runtime.zeros(n, np.float32)
    program.kernel("FmaProbe")((n,), None, fma.data, np.int32(rounds), np.float32(0.999), np.float32(1e-3))
    return launch, fma.get()


def test_probes_compute_what_they_claim(runtime):
    launch, fma = run_probes(runtime)
    np.testing.assert_allclose(launch, np.arange(64) * 2.0 + 1.0 + 0.5)
    np.testing.assert_allclose(fma, fma_probe_reference(64, 2, 0.999, 1e-3), rtol=1e-5)
    # FmaProbe seeds its chains with x0 = (i, i + 1, i + 2, i + 3) * 1e-9: below float32's step of the result at
    # ids < 64, but ~1e-3 (0.3 % of the result) at ids past 2^20, reached with a global offset
    offset, n = 2**20, 64
    out = runtime.zeros(offset + n, np.float32)
    kernel = cl.Kernel(runtime.program("probes").program, "FmaProbe")  # its own: Kernel caches what it last set
    kernel.set_args(out.data, np.int32(1), np.float32(0.999), np.float32(1e-3))
    cl.enqueue_nd_range_kernel(runtime.queue, kernel, (n,), None, global_work_offset=(offset,))
    np.testing.assert_allclose(out.get()[offset:], fma_probe_reference(n, 1, 0.999, 1e-3, first=offset), rtol=1e-5)


def test_measured_limits_are_positive_and_shares_follow_their_columns(runtime):
    assert copy_rate(runtime, 2**20) > 0 and fp32_rate(runtime) > 0
    assert read_back_rate(runtime, 2**20) > 0
    limits = DeviceLimits(copy_bytes_per_s=1e9, fp32_flops=1e12, host_bytes_per_s=2e8)
    rows = with_shares([{"size": 8, "Jacobi bytes/s": 2.5e8, "x flop/s": 5e11, "ms": 1.0}], limits)
    assert list(rows[0]) == ["size", "Jacobi bytes/s", "% copy bw", "x flop/s", "% FP32 peak", "ms"]
    assert rows[0]["% copy bw"] == pytest.approx(25.0) and rows[0]["% FP32 peak"] == pytest.approx(50.0)
    # two columns of one kind (marching cubes' field and mesh): each share is named after its column
    rows = with_shares([{"field bytes/s": 1e8, "mesh bytes/s": 2e8}], limits)
    assert rows[0] == {"field bytes/s": 1e8, "field % copy bw": 10.0, "mesh bytes/s": 2e8, "mesh % copy bw": 20.0}
    # a device-to-host rate is a share of the host link, not of the device's copies
    rows = with_shares([{"upload host bytes/s": 1e8, "mesh bytes/s": 2e8}], limits)
    assert rows[0] == {"upload host bytes/s": 1e8, "% host link": 50.0, "mesh bytes/s": 2e8, "% copy bw": 20.0}


@pytest.mark.oclgrind
def test_probes_are_clean_under_oclgrind(oclgrind):
    launch, fma = run_probes(oclgrind, n=16, rounds=1)
    np.testing.assert_allclose(fma, fma_probe_reference(16, 1, 0.999, 1e-3), rtol=1e-5)


# {{{ the counts behind each chapter's share column


STATED_COUNTS = {
    "sph_2d": ("PAIR_TEST_FLOPS", "PAIR_SUM_FLOPS"),
    "compute_intro": ("TEXEL_BYTES",),
    "grass": ("BLADE_BYTES",),
    "star_glow": ("TEXEL_BYTES",),
    "space_colonization": ("PAIR_FLOPS",),
    "kleinian": ("ITERATION_FLOPS",),
    "mcmc": ("STEP_FLOPS", "DENSITY_FLOPS", "LEGACY_PICK_FLOPS"),
    "cellular_growth": ("REPEL_TEST_FLOPS", "REPEL_CONTACT_FLOPS"),
    "poisson_disk": ("DART_ROUND_BYTES_PER_CELL", "SAMPLE_BYTES"),
    "multiplane_projection": ("MARCH_STEP_FLOPS", "SHAPE_DISTANCE_FLOPS"),
    "projection_spray": ("SPRAY_TEXEL_BYTES", "PAINT_TEXEL_BYTES"),
    "tessellation": ("FLUID_KERNEL_BYTES",),
    "procedural_modeling": ("GRID_VERTEX_BYTES", "GRID_CELL_BYTES", "TUBE_VERTEX_BYTES", "TUBE_RING_BYTES",
                            "TUBE_QUAD_BYTES"),
    "stable_fluids_2d": ("JACOBI_BYTES_PER_CELL",),
    "cloth": ("SUBSTEP_BYTES_PER_PARTICLE",),
    "boids": ("FLOPS_PER_PAIR",),
}  # fmt: skip


def leaves(value):
    """The numbers of a count: itself, or every value of a (nested) dict."""
    if isinstance(value, dict):
        for v in value.values():
            yield from leaves(v)
    else:
        yield value


@pytest.mark.parametrize("chapter", sorted(STATED_COUNTS))
def test_stated_counts_are_positive_numbers(chapter):
    module = importlib.import_module(f"ugpcl.bench.{chapter}")  # a bench states its counts beside it
    for name in STATED_COUNTS[chapter]:
        values = list(leaves(getattr(module, name)))
        assert values and all(isinstance(v, int | float) and not isinstance(v, bool) and v > 0 for v in values), name


def test_every_bench_row_has_a_share_column_or_a_dash():
    """Each chapter's bench states a count: its source names a `bytes/s` or `flop/s` column."""
    import inspect

    from ugpcl.bench import benches

    for name, bench in benches().items():
        if name in ("copy", "peak", "launch"):  # the device's limits themselves
            continue
        source = inspect.getsource(inspect.getmodule(bench))
        assert 'bytes/s"' in source or 'flop/s"' in source, name


def test_grid_pairs_are_the_pairs_of_neighbouring_cells():
    from ugpcl.bench.timing import grid_pairs_2d

    rng = np.random.default_rng(1)
    points = rng.uniform(-0.5, 4.5, (300, 2))  # some outside the 4 x 3 grid: clamped into its border cells
    i, j = grid_pairs_2d(points, (0.0, 0.0), 1.0, (4, 3, 1))
    cells = np.clip(np.floor(points), 0, [3, 2]).astype(int)
    near = np.all(np.abs(cells[:, None, :] - cells[None, :, :]) <= 1, axis=2) & ~np.eye(len(points), dtype=bool)
    assert sorted(zip(i.tolist(), j.tolist(), strict=True)) == sorted(zip(*np.nonzero(near), strict=True))


def test_star_glow_frame_bytes_follow_the_passes():
    from ugpcl.bench.star_glow import TEXEL_BYTES, frame_bytes

    W, H, w, h, n = 64, 32, 16, 8, 3
    # iteration 1: Brightness 5, streaks (book: per direction 2 + 3, comp cleared 1; fused: bright in, comp out),
    # Composite 2 W H + 1
    assert frame_bytes(W, H, w, h, n, 1, "book") == TEXEL_BYTES * (5 * w * h + (1 + n * 5) * w * h + 2 * W * H + w * h)
    assert frame_bytes(W, H, w, h, n, 1, "fused") == TEXEL_BYTES * (5 * w * h + 2 * w * h + 2 * W * H + w * h)
    # every extra pass: book 2 w h per direction; fused n layers read and written
    extra_book = frame_bytes(W, H, w, h, n, 3, "book") - frame_bytes(W, H, w, h, n, 2, "book")
    extra_fused = frame_bytes(W, H, w, h, n, 3, "fused") - frame_bytes(W, H, w, h, n, 2, "fused")
    assert extra_book == TEXEL_BYTES * 2 * n * w * h and extra_fused == TEXEL_BYTES * 2 * n * w * h


def test_tessellation_frame_bytes_count_the_launches_of_a_frame(runtime):
    from ugpcl.bench.tessellation import frame_bytes
    from ugpcl.scenes.tessellation import Params, Simulation

    sim = Simulation(runtime, Params(grid=32, variant="fixed", gs_iterations=2), seed=0)
    sim.step()  # the stroke is held from here on: every frame paints
    # brush 16, AddSourceVelocity 32, 2 diffusions 24, two projections (36 + 2 x 12 + 24), SwapVelocity 16,
    # AdvectVelocity 16, AddSourceDensity 16, 2 diffusions 12, SwapDensity 8, AdvectDensity 16, Draw 28
    assert frame_bytes(sim) == 388 * 32 * 32
    steps = sim.steps
    frame_bytes(sim)
    assert sim.steps == steps + 1 and "_grid" not in vars(sim.fluid)  # one real step; the counter is gone


@pytest.mark.parametrize(("chapter", "size", "share"), [("sph_2d", "256", "% FP32 peak"),
                                                        ("cellular_growth", "256", "% FP32 peak"),
                                                        ("tessellation", "32", "% copy bw")])  # fmt: skip
def test_small_bench_rows_carry_their_share(capsys, tmp_path, chapter, size, share):
    """A bench at a tiny size (well under 2 s on PoCL): every row has the share of its count, and --json holds it."""
    import json

    from ugpcl.cli import main

    out_json = tmp_path / "b.json"
    assert main(["bench", chapter, "--size", size, "--json", str(out_json)]) == 0
    table = capsys.readouterr().out
    assert share in table
    records = json.loads(out_json.read_text())
    rows = {json.dumps(r["labels"], sort_keys=True) for r in records}
    shares = [r for r in records if r["figure"] == share]
    assert len(shares) == len(rows) >= 2 and all(0 < r["value"] < 1000 for r in shares)
    assert not any("-" in r["labels"].values() for r in records)  # a "-" cell is no figure and no label


# }}}


def test_frames_bench_times_the_parts_of_a_frame(runtime):
    """``ugpcl bench frames`` on two scenes: a row each, at the sizes a CPU device starts the viewer with, whose frame
    is its step, upload and draw (the read-back of a picture apart), every part measured."""
    from ugpcl.bench.frames import bench

    rows = bench(runtime, scenes=["boids", "ear_clipping"])
    assert [(r["scene"], r["sizes"]) for r in rows] == [
        ("boids", "at scale (cpu)"), ("boids", "interactive"), ("ear_clipping", "defaults")
    ]  # fmt: skip
    assert rows[0]["upload MB"] == pytest.approx(16384 * 32 / 1e6)  # the boids' records, read back once a frame
    rows = rows[1:]
    for row in rows:
        parts = row["step ms"] + row["upload ms"] + row["draw ms"]
        assert row["ms/frame"] == pytest.approx(parts) and row["frames/s"] == pytest.approx(1e3 / parts)
        assert all(row[k] > 0 for k in ("step ms", "upload ms", "draw ms", "read-back ms"))
    assert rows[0]["sizes"] == "interactive"  # boids declares its CPU sizes
