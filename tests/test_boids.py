"""Boids (vol.1 ch.3; docs/chapters/03-boids.md): layout, ForceCS/IntegrateCS against numpy, rules, invariants, view."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import first_mismatch, foreground

from ugpcl.buffers import device_sizeof
from ugpcl.registry import get
from ugpcl.scenes.boids import BOID_DTYPE, FORCE_KERNELS, Params, Simulation

# {{{ numpy float64 reference, written from the book's Boids.compute listing


def limit(v: np.ndarray, max_length: float) -> np.ndarray:
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    scale = np.where((length > max_length) & (length > 0), max_length / np.maximum(length, 1e-300), 1.0)
    return v * scale


def steer(desired: np.ndarray, velocity: np.ndarray, p: Params) -> np.ndarray:
    length = np.linalg.norm(desired, axis=-1, keepdims=True)
    target = desired * (p.max_speed / np.maximum(length, 1e-300))
    return np.where(length > 0, limit(target - velocity, p.max_steer_force), 0.0)


def force_reference(position: np.ndarray, velocity: np.ndarray, p: Params) -> np.ndarray:
    """ForceCS for every boid against all others, float64."""
    pos, vel = position.astype(np.float64), velocity.astype(np.float64)
    diff = pos[:, None, :] - pos[None, :, :]  # P_position - N_position
    dist = np.linalg.norm(diff, axis=-1)
    near = dist > 0
    force = np.zeros_like(pos)
    rules = (
        ("sep", p.separate_neighborhood_radius, p.separate_weight),
        ("ali", p.alignment_neighborhood_radius, p.alignment_weight),
        ("coh", p.cohesion_neighborhood_radius, p.cohesion_weight),
    )
    for rule, radius, weight in rules:
        mask = near & (dist <= radius)
        count = mask.sum(axis=1, keepdims=True)
        if rule == "sep":
            terms = diff / np.where(mask, dist * dist, 1.0)[..., None]  # normalize(diff) / dist
            total = (terms * mask[..., None]).sum(axis=1)
        elif rule == "ali":
            total = mask.astype(np.float64) @ vel
        else:
            total = mask.astype(np.float64) @ pos
        mean = total / np.maximum(count, 1)
        desired = mean - pos if rule == "coh" else mean
        force += np.where(count > 0, steer(desired, vel, p), 0.0) * weight
    return force


def ambiguous_boids(position: np.ndarray, p: Params, margin: float = 1e-5) -> np.ndarray:
    """Boids with a neighbour within `margin` of a radius: float32 and float64 distances may put that neighbour on
    either side, so their forces are legitimately different."""
    pos = position.astype(np.float64)
    dist = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=-1)
    radii = (p.separate_neighborhood_radius, p.alignment_neighborhood_radius, p.cohesion_neighborhood_radius)
    return np.any([np.abs(dist - r) < margin * r for r in radii], axis=(0, 2))


def integrate_reference(position, velocity, force, dt: float, p: Params):
    pos, vel = position.astype(np.float64), velocity.astype(np.float64)
    lower = np.asarray(p.wall_center) - np.asarray(p.wall_size) / 2
    upper = np.asarray(p.wall_center) + np.asarray(p.wall_size) / 2
    wall = (pos < lower).astype(float) - (pos > upper).astype(float)
    vel = limit(vel + (force + wall * p.avoid_wall_weight) * dt, p.max_speed)
    return pos + vel * dt, vel


# }}}


def make(runtime, n: int, seed: int = 0, **overrides) -> Simulation:
    return Simulation(runtime, Params(max_object_num=n, **overrides), seed)


def spread_state(n: int, seed: int, half_size: float = 4.0):
    """Boids scattered through a box with random velocities: neighbourhoods of a few boids, as mid-flight."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-half_size, half_size, (n, 3)), rng.normal(0.0, 2.0, (n, 3))


# {{{ layout


def test_boid_dtype_matches_the_device_struct(runtime):
    assert BOID_DTYPE.itemsize == 32
    assert device_sizeof(runtime, "Boid", "boid.h") == BOID_DTYPE.itemsize


# }}}

# {{{ kernels vs reference


# one boid, under/at/over one tile, the chapter page's sizes; variant=auto: the kernel the device runs by default
@pytest.mark.parametrize("n", [1, 255, 256, 257, 512, 1000])
@pytest.mark.parametrize("start", ["book", "spread"])
def test_force_cs_matches_reference(runtime, n, start, seed):
    sim = make(runtime, n, seed)
    if start == "spread":
        sim.set_boids(*spread_state(n, seed))
    sim.force_cs()
    state = sim.state()
    expected = force_reference(state["position"], state["velocity"], sim.params)
    usable = ~ambiguous_boids(state["position"], sim.params)
    assert usable.mean() > 0.97, f"too many boundary cases ({(~usable).sum()}) for a meaningful comparison"
    # float32 sums of <= n terms against float64; the chapter page's tolerance (rtol 1e-4, atol 1e-5)
    actual, wanted = state["force"][usable], expected[usable]
    assert np.allclose(actual, wanted, rtol=1e-4, atol=1e-5), first_mismatch(actual, wanted, 1e-4, 1e-5)


@pytest.mark.parametrize("block", [64, 128])
def test_force_cs_with_smaller_blocks_matches_reference(runtime, block, seed):
    sim = make(runtime, 300, seed, simulation_block_size=block, variant="tiled")  # the block is ForceCS's tile
    assert sim.block_size == block
    sim.set_boids(*spread_state(300, seed, half_size=2.0))
    sim.force_cs()
    state = sim.state()
    expected = force_reference(state["position"], state["velocity"], sim.params)
    usable = ~ambiguous_boids(state["position"], sim.params)
    assert np.allclose(state["force"][usable], expected[usable], rtol=1e-4, atol=1e-5)


# ForceCS tests each radius on its own unless alignment and cohesion share the widest one (the book's radii, which
# every test above uses): that path too, with each rule's radius the widest in turn; 300 = a tile, a partial tile and
# a partial chunk of 8
@pytest.mark.parametrize("separate, alignment, cohesion", [(1.0, 2.5, 1.5), (1.0, 1.5, 2.5), (2.5, 1.0, 1.0)])
def test_tiled_force_cs_with_other_radii_matches_reference(runtime, separate, alignment, cohesion, seed):
    radii = {
        "separate_neighborhood_radius": separate,
        "alignment_neighborhood_radius": alignment,
        "cohesion_neighborhood_radius": cohesion,
    }
    sim = make(runtime, 300, seed, variant="tiled", **radii)
    sim.set_boids(*spread_state(300, seed, half_size=3.0))  # a few boids within 1, most within 2.5
    sim.force_cs()
    state = sim.state()
    expected = force_reference(state["position"], state["velocity"], sim.params)
    usable = ~ambiguous_boids(state["position"], sim.params)
    actual, wanted = state["force"][usable], expected[usable]
    assert np.allclose(actual, wanted, rtol=1e-4, atol=1e-5), first_mismatch(actual, wanted, 1e-4, 1e-5)


def test_tiled_force_cs_takes_pairs_closer_than_1e_19_for_coincident(runtime):
    """ForceCS's near test is dist^2 >= FLT_MIN (the book's dist > 0 less the subnormal squares, whose reciprocal
    NVIDIA's rcp.approx.ftz makes infinite): two boids 1e-20 apart ignore each other and feel no force."""
    sim = make(runtime, 2, variant="tiled")
    sim.set_boids([[1e-20, 0.0, 0.0], [0.0, 0.0, 0.0]], [[0.5, 0, 0], [0, 0.5, 0]])
    sim.force_cs()
    np.testing.assert_array_equal(sim.state()["force"], 0.0)


def recording_launches(sim, monkeypatch) -> list[str]:
    """The names of the kernels ``sim`` fetches from its program from now on (one fetch per launch)."""
    launched, kernel = [], sim.program.kernel
    monkeypatch.setattr(sim.program, "kernel", lambda name: (launched.append(name), kernel(name))[1])
    return launched


# every variant on every device, each its own kernel: tiled the book's __local tiles (on PoCL too), lanes the CPU's
# vector lanes (n = 17: one lane group of 16 plus one boid; 257: one tile plus one boid; 1000: 63 lane groups and
# 4 tiles, the last ones partial)
@pytest.mark.parametrize("variant", ["tiled", "lanes", "naive", "grid"])
@pytest.mark.parametrize("n", [17, 257, 1000])
@pytest.mark.parametrize("start", ["book", "spread"])
def test_each_variant_matches_reference(runtime, variant, n, start, seed, monkeypatch):
    sim = make(runtime, n, seed, variant=variant)
    if start == "spread":
        sim.set_boids(*spread_state(n, seed))
    launched = recording_launches(sim, monkeypatch)
    sim.force_cs()
    assert launched == [FORCE_KERNELS[variant]] == [sim.stats()["ForceCS kernel"]]
    state = sim.state()
    expected = force_reference(state["position"], state["velocity"], sim.params)
    usable = ~ambiguous_boids(state["position"], sim.params)
    actual, wanted = state["force"][usable], expected[usable]
    assert np.allclose(actual, wanted, rtol=1e-4, atol=1e-5), first_mismatch(actual, wanted, 1e-4, 1e-5)
    naive = make(runtime, n, seed, variant="naive")
    naive.set_boids(state["position"], state["velocity"])
    naive.force_cs()
    # neighbours in index order in the all-pairs kernels: tiled has naive's sums but steers separation and alignment
    # by their sum instead of their mean (the same direction; a few ulp apart after steer's normalisation: up to
    # 1e-6 over 72 spread and book starts on PoCL, hence 1e-5); lanes' float16 arithmetic is contracted differently
    # by PoCL from n = 257 on (a few ulp in the sums, amplified by steer's normalisation: up to 2e-6 over 39 spread
    # and book starts, hence 1e-5); the grid visits them in cell order: equal up to float rounding of the sums
    rtol, atol = {"tiled": (1e-5, 1e-5), "lanes": (1e-5, 1e-5), "naive": (0.0, 0.0), "grid": (1e-4, 1e-5)}[variant]
    np.testing.assert_allclose(state["force"], naive.state()["force"], rtol=rtol, atol=atol)


def test_variant_names_map_to_kernels_and_auto_follows_the_device(runtime, monkeypatch):
    sim = make(runtime, 64)
    assert sim.params.variant == "auto"
    expected = "ForceCS" if runtime.is_gpu else "ForceCS_cpu"  # the fixture's devices: PoCL or a GPU
    launched = recording_launches(sim, monkeypatch)
    sim.force_cs()
    assert launched == [expected] and sim.stats()["ForceCS kernel"] == expected
    assert sim.stats()["variant"] == "auto"
    mapping = {"tiled": "ForceCS", "lanes": "ForceCS_cpu", "naive": "ForceCS_naive", "grid": "ForceCS_grid"}
    assert FORCE_KERNELS == mapping
    for variant, kernel in mapping.items():  # live: the next ForceCS runs the new kernel, on any device
        sim.update(variant=variant)
        launched.clear()
        sim.force_cs()
        assert launched[-1] == kernel == sim.force_kernel() == sim.stats()["ForceCS kernel"], variant
        assert sim.stats()["variant"] == variant


@pytest.mark.parametrize("variant", ["tiled", "lanes"])
def test_run_summary_names_the_kernel_that_ran(variant, tmp_path, capsys):
    from ugpcl.cli import main

    out = tmp_path / "x.npz"
    assert (
        main(["run", "boids", "--steps", "2", "--set", "max_object_num=64", f"variant={variant}", "--out", str(out)])
        == 0
    )
    lines = capsys.readouterr().out.splitlines()
    assert f"  variant: {variant}" in lines and f"  ForceCS kernel: {FORCE_KERNELS[variant]}" in lines
    main(["run", "boids", "--steps", "2", "--set", "max_object_num=64", "--out", str(out)])
    lines = capsys.readouterr().out.splitlines()
    assert "  variant: auto" in lines
    kernel = [line for line in lines if line.startswith("  ForceCS kernel: ")]
    assert kernel in (["  ForceCS kernel: ForceCS"], ["  ForceCS kernel: ForceCS_cpu"])  # the CLI's device


@pytest.mark.parametrize("start", ["book", "spread", "escaped"])
def test_grid_variant_matches_all_pairs(runtime, start, seed):
    n = 1000
    all_pairs, grid = make(runtime, n, seed), make(runtime, n, seed, variant="grid")
    if start != "book":
        position, velocity = spread_state(n, seed, half_size=4.0 if start == "spread" else 30.0)
        all_pairs.set_boids(position, velocity)  # "escaped": many boids outside the box, in the grid's border cells
        grid.set_boids(position, velocity)
    all_pairs.force_cs()
    grid.force_cs()
    # the same neighbours, visited in cell order instead of index order: equal up to float rounding of the sums
    np.testing.assert_allclose(grid.state()["force"], all_pairs.state()["force"], rtol=1e-4, atol=1e-5)


def test_integrate_cs_matches_reference(runtime, seed):
    n = 700
    sim = make(runtime, n, seed)
    position, velocity = spread_state(n, seed, half_size=20.0)  # some boids outside the 32^3 box: wall force
    sim.set_boids(position, velocity * 3)
    sim.force_cs()
    before = sim.state()
    dt = 1.0 / 60.0
    sim.integrate_cs(dt)
    after = sim.state()
    pos, vel = integrate_reference(before["position"], before["velocity"], before["force"], dt, sim.params)
    np.testing.assert_allclose(after["velocity"], vel, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(after["position"], pos, rtol=1e-5, atol=1e-6)


# }}}

# {{{ rules one at a time


def only(rule: str, **extra) -> dict:
    weights = {"separate_weight": 0.0, "alignment_weight": 0.0, "cohesion_weight": 0.0}
    weights[rule] = {"separate_weight": 3.0, "alignment_weight": 1.0, "cohesion_weight": 1.0}[rule]
    return {**weights, **extra}


def test_single_boid_and_coincident_pair_feel_no_force(runtime):
    one = make(runtime, 1)
    one.force_cs()
    np.testing.assert_array_equal(one.state()["force"], 0.0)
    pair = make(runtime, 2)
    pair.set_boids([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]], [[0.5, 0, 0], [0, 0.5, 0]])
    pair.force_cs()
    np.testing.assert_array_equal(pair.state()["force"], 0.0)  # dist > 0 test: they ignore each other


def test_separation_pushes_two_resting_boids_apart(runtime):
    sim = make(runtime, 2, **only("separate_weight"))
    sim.set_boids([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]], np.zeros((2, 3)))
    sim.force_cs()
    force = sim.state()["force"]
    expected = sim.params.max_steer_force * sim.params.separate_weight  # = 1.5
    np.testing.assert_allclose(force[0], [-expected, 0, 0], atol=1e-6)
    np.testing.assert_allclose(force[1], -force[0], atol=1e-6)  # antisymmetric


def test_alignment_at_full_speed_is_zero_and_below_it_is_parallel(runtime, seed):
    rng = np.random.default_rng(seed)
    position = rng.uniform(-0.5, 0.5, (50, 3))
    direction = np.array([0.6, 0.0, 0.8])
    sim = make(runtime, 50, **only("alignment_weight"))
    sim.set_boids(position, np.tile(direction * sim.params.max_speed, (50, 1)))
    sim.force_cs()
    np.testing.assert_allclose(sim.state()["force"], 0.0, atol=1e-5)
    sim.set_boids(position, np.tile(direction * 1.0, (50, 1)))
    sim.force_cs()
    force = sim.state()["force"]
    cosine = force @ direction / np.linalg.norm(force, axis=1)
    np.testing.assert_allclose(cosine, 1.0, atol=1e-6)


def test_cohesion_points_resting_boids_at_the_centroid(runtime, seed):
    rng = np.random.default_rng(seed)
    position = rng.uniform(-0.6, 0.6, (40, 3))  # all within the cohesion radius 2 of each other
    sim = make(runtime, 40, **only("cohesion_weight"))
    sim.set_boids(position, np.zeros((40, 3)))
    sim.force_cs()
    force = sim.state()["force"]
    others = (position.sum(axis=0) - position) / 39  # centroid of everyone else
    to_centroid = others - position
    cosine = np.sum(force * to_centroid, axis=1) / np.linalg.norm(force, axis=1) / np.linalg.norm(to_centroid, axis=1)
    np.testing.assert_allclose(cosine, 1.0, atol=1e-5)


# }}}

# {{{ integration invariants


def test_wall_turns_a_boid_back_and_is_zero_inside(runtime):
    sim = make(runtime, 2)
    sim.set_boids([[20.0, 0.0, 0.0], [-5.0, 3.0, 1.0]], np.zeros((2, 3)))  # far apart: no rule acts
    sim.step(1.0 / 60.0)
    velocity = sim.state()["velocity"]
    assert velocity[0, 0] < 0, "the boid outside the box (x = 20 > 16) was not pushed back"
    np.testing.assert_array_equal(velocity[1], 0.0)  # inside the box the wall term is exactly 0


def test_a_boid_on_a_wall_feels_no_wall_force(runtime):
    """Book's avoidWall: +1 only below c - s/2, -1 only above c + s/2 (strict), so a boid exactly on a face of the
    32^3 box (at +-16, exact in float) is still inside; a boid a step past it is pushed back."""
    on_faces = np.array([[16, 0, 0], [-16, 0, 0], [0, 16, 0], [0, -16, 0], [0, 0, 16], [0, 0, -16]], float)
    # 16.015625: just outside the same six faces, 8 away from the face's centre along both other axes
    past = on_faces * (1 + 2**-10) + (on_faces == 0) * 8.0
    sim = make(runtime, 12)  # every pair > 8 apart, 4 times the largest radius: no rule acts, only the wall
    sim.set_boids(np.concatenate([on_faces, past]), np.zeros((12, 3)))
    sim.step(1.0 / 60.0)
    velocity = sim.state()["velocity"]
    np.testing.assert_array_equal(velocity[:6], 0.0)
    expected = -np.sign(on_faces) * sim.params.avoid_wall_weight / 60.0  # one push of weight 10 for dt = 1/60
    np.testing.assert_allclose(velocity[6:], expected, rtol=1e-6)


def test_speed_limit_holds_after_every_step(runtime, seed):
    sim = make(runtime, 600, seed)
    for _ in range(60):
        sim.step()
        speed = np.linalg.norm(sim.state()["velocity"], axis=1)
        assert speed.max() <= sim.params.max_speed * (1 + 1e-6)


@pytest.mark.slow
def test_long_run_stays_bounded(runtime):
    sim = make(runtime, 1024, seed=0)
    for _ in range(1200):
        sim.step(1.0 / 60.0)
    state = sim.state()
    assert np.isfinite(state["position"]).all() and np.isfinite(state["velocity"]).all()
    # numpy prototype: max |pos| stayed <= 17; the wall only acts outside the box, so allow an overshoot of 3
    assert np.abs(state["position"]).max() <= 16 + 3
    speed = np.linalg.norm(state["velocity"], axis=1).mean()
    assert 0 < speed <= sim.params.max_speed


def test_same_seed_same_device_is_bitwise_identical(runtime):
    a, b = make(runtime, 512, seed=7), make(runtime, 512, seed=7)
    for _ in range(100):
        a.step()
        b.step()
    for key in ("position", "velocity", "force"):
        np.testing.assert_array_equal(a.state()[key], b.state()[key])
    c = make(runtime, 512, seed=8)
    assert not np.array_equal(a.state()["position"], (c.step(), c.state()["position"])[1])


def test_initial_state_is_the_books(runtime):
    state = make(runtime, 4096, seed=1).state()
    assert np.linalg.norm(state["position"], axis=1).max() <= 1.0 + 1e-6
    assert np.linalg.norm(state["velocity"], axis=1).max() <= 0.1 + 1e-6
    assert np.linalg.norm(state["position"], axis=1).mean() > 0.7  # uniform in the ball: mean radius 3/4


# }}}

# {{{ parameters


# out-of-range values (every field of every scene), NaN, tuple lengths, types: tests/test_params.py
@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"simulation_block_size": 100}, "simulation_block_size must be one of"),
        ({"variant": "fast"}, "variant must be one of auto\\|tiled\\|lanes\\|naive\\|grid"),
    ],
)
def test_bad_choices_name_the_field_and_the_choices(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_bad_dt_is_refused(runtime):
    sim = make(runtime, 4)
    for dt in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="dt must be in \\(0, 1\\]"):
            sim.step(dt)


# }}}

# {{{ view


@pytest.mark.gl
@pytest.mark.parametrize("shape", ["cubes", "points"])
def test_view_draws_boids_where_they_are(runtime, gl, shape, monkeypatch):
    """Each boid's centre pixel is drawn and nothing far from every boid; as instanced cubes, or as one point each
    (what the view draws above POINT_BOIDS boids: lowered here to draw these 24 as points)."""
    import ugpcl.viewer.views.boids as boids_view
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    if shape == "points":
        monkeypatch.setattr(boids_view, "POINT_BOIDS", 0)

    scene = get("boids")
    rng = np.random.default_rng(3)
    n = 24
    position = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-1, 3, n)])
    sim = scene.create(runtime, max_object_num=n, object_scale=(0.4, 0.4, 0.4))
    sim.set_boids(position, rng.normal(size=(n, 3)))
    view = create_view(scene, gl, sim)
    view.show_box = False
    camera = view.book_camera()  # close up: the first view (make_camera) is the whole box from outside
    size = (160, 120)
    camera.aspect = size[0] / size[1]
    view.upload()
    query = gl.query(primitives=True)
    with query:
        pixels = frame(size).render(view, camera)
    assert query.primitives == (12 * n if shape == "cubes" else n), "one cube (12 triangles) or one point per boid"
    mask = foreground(pixels, view.background)
    # project every boid centre with the camera and look at that pixel
    clip = (camera.projection() @ camera.view() @ np.column_stack([position, np.ones(n)]).T).T
    ndc = clip[:, :2] / clip[:, 3:]
    px = np.round((ndc[:, 0] + 1) / 2 * size[0] - 0.5).astype(int)
    py = np.round((1 - ndc[:, 1]) / 2 * size[1] - 0.5).astype(int)  # image row 0 is the top
    inside = (px >= 0) & (px < size[0]) & (py >= 0) & (py < size[1])
    assert inside.sum() >= n // 2
    assert mask[py[inside], px[inside]].all(), "a boid's centre pixel shows background"
    # and nothing is drawn far from every boid
    yy, xx = np.mgrid[0 : size[1], 0 : size[0]]
    near = np.zeros(size[::-1], bool)
    for x, y in zip(px, py, strict=True):
        near |= (xx - x) ** 2 + (yy - y) ** 2 < 12**2
    assert not (mask & ~near).any(), "boid pixels where no boid is"
    assert mask.mean() > 0.005


@pytest.mark.gl
def test_view_keys_change_the_simulation(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("boids")
    sim = scene.create(runtime, max_object_num=512)
    view = create_view(scene, gl, sim)
    view.more_boids()
    assert sim.n == 1024
    view.toggle_separation()
    assert sim.params.separate_weight == 0.0
    view.toggle_separation()
    assert sim.params.separate_weight == 3.0
    assert sim.params.variant == "auto"
    for variant in ("tiled", "lanes", "naive", "grid", "auto"):
        view.next_variant()
        assert sim.params.variant == variant
        assert f"ForceCS: {variant} ({sim.force_kernel()})" in view.status()[0]
    assert {k.key for k in view.keys} >= {"[", "]", "+", "-", "1", "2", "3", "tab", "b"}


# }}}


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind, seed):
    sim = Simulation(oclgrind, Params(max_object_num=300, simulation_block_size=64), seed)
    sim.set_boids(*spread_state(300, seed, half_size=1.5))
    sim.step()  # ForceCS: 5 tiles of 64, the last one partial; IntegrateCS
    naive = Simulation(oclgrind, Params(max_object_num=300, simulation_block_size=64, variant="naive"), seed)
    naive.set_boids(*spread_state(300, seed, half_size=1.5))
    naive.step()
    np.testing.assert_allclose(sim.state()["position"], naive.state()["position"], rtol=1e-6, atol=1e-6)
    assert sim.force_kernel() == "ForceCS"  # variant=auto: Oclgrind checks the book's barriers
    lanes = Simulation(oclgrind, Params(max_object_num=300, variant="lanes"), seed)  # 19 work-items of 16 lanes,
    # the last one with 12 boids
    lanes.set_boids(*spread_state(300, seed, half_size=1.5))
    lanes.step()
    np.testing.assert_allclose(lanes.state()["position"], naive.state()["position"], rtol=1e-6, atol=1e-6)
    grid = Simulation(oclgrind, Params(max_object_num=300, variant="grid"), seed)
    grid.set_boids(*spread_state(300, seed, half_size=1.5))
    grid.step()  # GridHash, the scan, GridScatter, GridSortCells, GridCopyItemsInCellOrder, ForceCS_grid
    np.testing.assert_allclose(grid.state()["position"], naive.state()["position"], rtol=1e-5, atol=1e-5)
    packed, box = grid.packed_boids()  # PackBoidsHalf: the view's half-float copy and the flock's bounding box
    packed, state = packed.get().astype(np.float32), grid.state()
    np.testing.assert_allclose(packed[:, :3], state["position"], rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(packed[:, 4:7], state["velocity"], rtol=1e-3, atol=1e-3)
    assert np.array_equal(box, [state["position"].min(axis=0), state["position"].max(axis=0)])


@pytest.mark.parametrize("n", [300, 512])
def test_packed_boids_are_the_boids_in_half_floats_with_their_bounding_box(runtime, seed, n):
    """PackBoidsHalf (the view's copy of a flock drawn as points): position then velocity as half4 per boid, and the
    positions' bounding box reduced on the device exactly (a partial last work-group, negative coordinates, the
    smallest and largest in various boids)."""
    sim = Simulation(runtime, Params(max_object_num=n), seed)
    rng = np.random.default_rng(seed)
    position = rng.uniform(-40.0, 25.0, (n, 3)).astype(np.float32)
    position[0], position[-2] = -50.0, 30.0  # the extremes at even places of a work-group, where a tree keeps them
    sim.set_boids(position, rng.normal(size=(n, 3)))
    packed, box = sim.packed_boids()
    packed, state = packed.get().astype(np.float32), sim.state()
    np.testing.assert_allclose(packed[:, :3], state["position"], rtol=1e-3, atol=2e-2)
    np.testing.assert_allclose(packed[:, 4:7], state["velocity"], rtol=1e-3, atol=1e-3)
    assert np.array_equal(box, [state["position"].min(axis=0), state["position"].max(axis=0)])
