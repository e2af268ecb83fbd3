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
