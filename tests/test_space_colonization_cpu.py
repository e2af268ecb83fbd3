"""The blog's CPU space colonization (B. Olij 2014, next to vol.4 ch.1; docs/chapters/12-space-colonization.md): the
attraction shells, the crown and roots stages with and without the repeat guard, the CLI and the view. No kernels,
so no layout or Oclgrind tests."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import render_view, run_cli

from ugpcl.geometry.space_colonization import hemisphere_cloud
from ugpcl.registry import get
from ugpcl.scenes.space_colonization_cpu import Params, Simulation

# {{{ the blog's tree


def descends_from(segments: np.ndarray, vertex: int, root: int) -> bool:
    parent = {b: a for a, b in segments}
    while vertex in parent and vertex != root:
        vertex = parent[vertex]
    return vertex == root


def test_blog_points_are_in_their_shell(seed):
    rng = np.random.default_rng(seed)
    outer, inner, aspect, offset = 75.0, 50.0, 2.0, 30.0
    p = hemisphere_cloud(5000, outer, inner, aspect, offset, rng)
    assert (p[:, 1] >= offset).all()
    r = np.linalg.norm(np.column_stack([p[:, 0], (p[:, 1] - offset) / aspect, p[:, 2]]), axis=1)
    assert (r >= inner - 1e-9).all() and (r < outer).all()


def test_blog_tree_demo_with_repeat_guard(runtime, seed):
    sim = Simulation(runtime, Params(repeat_guard=True, clear_leftovers=True), seed)
    while not sim.finished:
        sim.step()
    state = sim.state()
    crown, roots = state["stage_iterations"]
    first_root = int(state["root_stage_first_vertex"])
    assert 60 <= crown <= 200 and 2000 <= first_root <= 3500
    segments = state["segments"]
    vertices = state["vertices"]
    p = sim.params
    # every branch: a normalised step plus the stage's bias (the trunk is the first segment)
    step = vertices[segments[1:, 1]] - vertices[segments[1:, 0]]
    bias = np.where((segments[1:, 1] >= first_root)[:, None], p.root_bias, p.bias)
    np.testing.assert_allclose(np.linalg.norm(step - bias, axis=1), p.branch_size, atol=1e-9)
    # the only-new-vertices search: root points start at vertex 0 and never see the old crown vertices
    new = np.arange(first_root, len(vertices))
    assert len(new) > 20 and roots > 5
    assert all(descends_from(segments, v, 0) and not descends_from(segments, v, 1) for v in new)


def test_blog_crown_leaves_few_points(runtime, seed):
    sim = Simulation(runtime, Params(repeat_guard=True), seed)
    while sim.stage == 0:
        sim.step()
    stuck = len(sim.tree.points) - sim.params.root_points  # the roots cloud was just appended to the leftovers
    assert 0 <= stuck <= 0.02 * sum(sim.params.crown_points)
    assert 2000 <= sim.root_stage_first_vertex <= 3500 and 60 <= sim.stage_iterations[0] <= 200


def test_blog_without_the_guard_is_ended_by_the_stall_detector(runtime):
    sim = Simulation(runtime, Params(max_iterations=400, repeat_guard=False), 1)
    while not sim.finished:
        sim.step()
    state = sim.state()
    assert state["stalled"][0], "the crown stage should end with trapped points left"
    assert state["stage_iterations"][0] < 400, "the stall detector did not fire"
    vertices = state["vertices"]
    _, counts = np.unique(np.round(vertices, 9), axis=0, return_counts=True)
    assert counts.max() > 1, "without the guard a trapped vertex regrows to the same point"


def test_the_scene_runs_ten_iterations_a_step(runtime):
    """The scene's pace (10 doIterations a step) grows the demo's tree (1 a step) ten times as fast, vertex for
    vertex, and 10 steps end the crown stage: a short run shows the grown tree."""
    fast = get("space_colonization_cpu").create(runtime, 2)
    demo = Simulation(runtime, Params(), 2)
    for _ in range(3):
        fast.step()
    for _ in range(30):
        demo.step()
    np.testing.assert_array_equal(fast.tree.vertices, demo.tree.vertices)
    for _ in range(7):
        fast.step()
    assert fast.stage >= 1 and len(fast.tree.vertices) > 2000


# }}}

# {{{ headless CLI


def test_cli_writes_the_chapter_arrays(capsys, tmp_path):
    out = tmp_path / "cpu.npz"
    code, text = run_cli(
        capsys, "run", "space_colonization_cpu", "--steps", "400", "--set", "repeat_guard=true", "--out", str(out)
    )
    assert code == 0, text
    data = np.load(out)
    assert data["vertices"].dtype == np.float64 and data["segments"].dtype == np.int32
    assert data["stage_iterations"].shape == (2,) and data["stalled"].dtype == bool
    assert len(data["segments"]) == len(data["vertices"]) - 1 and int(data["root_stage_first_vertex"]) > 2000


# }}}

# {{{ views


@pytest.mark.gl
def test_cpu_view_draws_brown_branches(runtime, gl):
    sim = get("space_colonization_cpu").create(runtime, 0, iterations=1)  # the demo's pace: 60 iterations
    for _ in range(60):
        sim.step()
    pixels = render_view(gl, "space_colonization_cpu", sim, rotate=False)[0]
    brown = (pixels[..., 0] > 100) & (pixels[..., 1] > 30) & (pixels[..., 1] < pixels[..., 0]) & (pixels[..., 2] < 40)
    assert brown.sum() > 300
    ys, xs = np.nonzero(brown)
    assert abs(xs.mean() - 80) < 25  # the tree stands in the middle


# }}}
