"""``Scene.interactive``: the sizes the viewer starts a scene at on a CPU device. Each override is a valid parameter
that changes its default, and every scene too slow at its book size on PoCL has them. How fast they step is measured
by benches, not here (a timed test would fail on a busy machine): ~50 ms per step on this 2-core PoCL machine when
they were chosen."""

from __future__ import annotations

import numpy as np
import pytest

from ugpcl.registry import scenes

SIZED = [name for name, scene in scenes().items() if scene.interactive]
"""Scenes that declare CPU sizes (``Scene.interactive``): their book sizes step too slowly on PoCL for a window."""


@pytest.mark.parametrize("name", sorted(scenes()))
def test_overrides_are_valid_params_that_change_a_default(name):
    scene = scenes()[name]
    sized, book = scene.params(**scene.interactive), scene.params()
    for key, value in scene.interactive.items():
        assert getattr(sized, key) == value, f"{name}: {key} not applied"
        assert getattr(book, key) != value, f"{name}: interactive {key}={value!r} is already the default"


AT_SCALE = [name for name, scene in scenes().items() if scene.at_scale]
"""The flagship scenes (``Scene.at_scale``): their production sizes on a GPU and the same workload shrunk for a CPU."""


def test_the_flagship_scenes_declare_their_production_sizes():
    assert {"boids", "sph_2d", "cloth", "stable_fluids_2d", "stable_fluids_3d", "marching_cubes", "kleinian",
            "space_colonization", "cellular_growth"} <= set(AT_SCALE)  # fmt: skip


@pytest.mark.parametrize("name", AT_SCALE)
def test_at_scale_sizes_are_valid_params_and_the_cpu_ones_run(runtime, name):
    """Both size sets pass their Params' checks (ranges, cross-field limits) without allocating; the GPU one is the
    larger (each size it sets is at least the CPU one's), and the CPU one steps here."""
    scale = scenes()[name].at_scale
    gpu, cpu = scenes()[name].params(**scale.gpu), scenes()[name].params(**scale.cpu)
    assert set(scale.gpu) == set(scale.cpu), f"{name}: the CPU workload sets other parameters than the GPU one"
    for key in scale.gpu:
        assert getattr(gpu, key) == scale.gpu[key] and getattr(cpu, key) == scale.cpu[key]
    sizes = [k for k, v in scale.gpu.items() if isinstance(v, int | float | tuple) and not isinstance(v, bool)]
    assert sizes, f"{name}: at_scale sets no size"
    sim = scenes()[name].create(runtime, 0, **scale.cpu)
    sim.step()
    runtime.finish()
    assert sim.steps == 1 and cpu != gpu


@pytest.mark.parametrize("name", SIZED)
def test_scenes_too_slow_at_book_size_have_cpu_sizes_that_run(runtime, name):
    scene = scenes()[name]
    assert scene.interactive, f"{name} has no interactive sizes"
    sim = scene.create(runtime, 0, **scene.interactive)
    sim.step()
    runtime.finish()
    assert sim.steps == 1


def test_the_huds_frame_parts_never_exceed_the_frame():
    """FrameTimes: frames of random lengths, each with its simulation and drawing inside it (and, as on a real
    screen, a first frame with no parts yet): the averaged sim + draw never exceeds the averaged frame."""
    from ugpcl.viewer.app import FrameTimes

    rng = np.random.default_rng(0)
    times, now = FrameTimes(), 0.0
    for k in range(500):
        times.start(now)
        frame = float(rng.choice([0.001, 0.016, 0.3])) * rng.uniform(0.5, 2.0)
        if k:  # the first frame reports no parts (as a window's first frame may)
            split = rng.dirichlet([1.0, 1.0, 1.0]) * frame
            times.parts(float(split[0]), float(split[1]))
        now += frame
        if times.samples:
            assert times.sim + times.draw <= times.frame * (1 + 1e-12), (k, times.frame, times.sim, times.draw)
    assert times.samples == 498 and times.frame > 0
