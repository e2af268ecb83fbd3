"""What a newcomer's first command shows: ``ugpcl run SCENE --steps 10 --png x.png`` for every scene, at the default
``--png`` size (800x600) and at the previews' (1280x720), judged by the preview pictures' measures (the scene's
``preview_check``): the subject large enough and whole, clear of the frame's edge at both aspect ratios."""

from __future__ import annotations

import pytest
from helpers import judge_picture

from ugpcl.registry import scenes

SIZES = [(800, 600), (1280, 720)]


@pytest.mark.gl
@pytest.mark.parametrize("name", list(scenes()))
def test_ten_steps_show_the_subject(runtime, gl, name):
    from ugpcl.viewer.offscreen import render

    scene = scenes()[name]
    sim = scene.create(runtime)
    for _ in range(10):
        sim.step(scene.simulation.default_dt)
    for size in SIZES:
        judge_picture(render(scene, sim, size), scene.preview_check, f"{name} after 10 steps at {size[0]}x{size[1]}")
