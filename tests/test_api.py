"""The Python API the README shows: its code block runs as written."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from helpers import foreground
from PIL import Image

import ugpcl

README = Path(__file__).resolve().parents[1] / "README.md"


def readme_example() -> str:
    text = README.read_text()
    match = re.search(r"<!-- the test suite runs this block.*?-->\n```python\n(.*?)```", text, re.S)
    assert match, "README.md lost its Python example"
    return match.group(1)


def test_readme_example_is_short():
    assert len(readme_example().strip().splitlines()) <= 12


@pytest.mark.gl
def test_readme_example_runs(tmp_path, monkeypatch, gl, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(readme_example(), "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "'boids':" in out and "(1024, 3)" in out
    pixels = np.asarray(Image.open(tmp_path / "boids.png").convert("RGB"))
    assert foreground(pixels, (0.192, 0.302, 0.475)).sum() > 100, "the picture shows nothing"


def test_create_validates_and_update_resets_only_for_non_live_params():
    sim = ugpcl.create("boids", seed=1, device="pocl", max_object_num=256)
    assert sim.scene.name == "boids" and sim.params.max_object_num == 256
    sim.step()
    sim.update(cohesion_weight=2.0)  # live
    assert sim.steps == 1
    sim.update(max_object_num=128)  # not live: a new run
    assert sim.steps == 0 and sim.state()["position"].shape == (128, 3)
    with pytest.raises(ValueError, match="max_object_num must be in"):
        ugpcl.create("boids", max_object_num=0, device="pocl")
    with pytest.raises(ValueError, match="unknown scene 'boidz'"):
        ugpcl.create("boidz", device="pocl")


def test_scenes_lists_every_scene_with_its_summary():
    listed = ugpcl.list_scenes()
    assert "boids" in listed and "flocking" in listed["boids"] and len(listed) >= 20


def test_update_says_when_it_resets(runtime):
    """A live parameter changes in place; any other resets the simulation, with a ParameterReset naming it."""
    import warnings

    from ugpcl.scene import ParameterReset

    sim = ugpcl.create("boids", device=runtime, max_object_num=256)
    sim.step()
    sim.step()
    live = sorted(sim.params.live_names())[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert sim.update(**{live: getattr(sim.params, live)}) is False  # nothing changed
    with pytest.warns(ParameterReset, match="max_object_num is not live"):
        assert sim.update(max_object_num=512) is True
    assert sim.steps == 0
