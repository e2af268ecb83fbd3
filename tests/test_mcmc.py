"""MCMC sampling (vol.1 ch.8; docs/chapters/08-mcmc.md): noise and density against numpy, the samplers' statistics,
trajectories against the numpy twin, rejection and pi, the CLI arrays, the view, Oclgrind; and tests/stats.py."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import foreground, render_view, run_cli
from reference.mcmc import density_numpy, lattice_numpy, noise_numpy, sequence_numpy
from scipy.signal import lfilter
from stats import chi2_pvalue, effective_sample_size, integrated_time, ks_pvalue, total_variation

from ugpcl.random import philox4x32, uniform01
from ugpcl.scenes.mcmc import PURPOSE_REJECTION, Params, Simulation


def make(runtime, seed: int = 0, **overrides) -> Simulation:
    return Simulation(runtime, Params(**overrides), seed)


def full_density(W: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The book's O(L^3) sum over every lattice point, float64, no truncation."""
    L = W.shape[0]
    axis = np.arange(L, dtype=np.float64)
    pts = np.asarray(points, np.float64)
    ex, ey, ez = (np.exp(-((pts[:, a, None] - axis) ** 2)) for a in range(3))  # (n, L) each: exp separates
    return np.einsum("nk,nj,ni,kji->n", ez, ey, ex, np.asarray(W, np.float64))


# {{{ tests/stats.py


def test_stats_helpers_on_known_distributions():
    rng = np.random.default_rng(1)
    counts = np.bincount(rng.integers(0, 10, 20000), minlength=10)
    assert chi2_pvalue(counts, np.ones(10)) > 1e-3
    assert chi2_pvalue(counts, np.arange(1, 11)) < 1e-12  # the wrong distribution is refused
    assert ks_pvalue(rng.random(5000)) > 1e-3 and ks_pvalue(rng.random(5000) ** 1.2) < 1e-6
    assert total_variation([1, 1, 0, 0], [0, 0, 2, 2]) == 1.0 and total_variation([1, 2], [2, 4]) == 0.0
    # AR(1) with phi: tau = (1 + phi) / (1 - phi); phi = 0.5 -> 3, and i.i.d. -> 1
    phi, n = 0.5, 200000
    noise = rng.normal(size=(4, n))
    x = lfilter([1.0], [1.0, -phi], noise, axis=1)  # x_t = phi x_(t-1) + noise_t
    assert abs(integrated_time(x) - 3.0) < 0.15
    assert abs(integrated_time(noise) - 1.0) < 0.05
    assert abs(effective_sample_size(x) - x.size / 3.0) < 0.05 * x.size / 3.0


# }}}

# {{{ noise and density


def test_noise_kernel_matches_numpy_twin(runtime, seed):
    sim = make(runtime, L=30, chains=1)
    points = np.random.default_rng(seed).uniform(-40, 40, (10000, 3)).astype(np.float32)
    assert np.abs(sim.noise_at(points) - noise_numpy(points, sim.T)).max() < 1e-6
    # on the planes x = y, y = z, x = z two offsets tie (u = v, v = w, u = w exactly): Perlin's reference breaks the
    # ties as hi = u >= w ? (u >= v ? 0 : 1) : (v >= w ? 1 : 2), and the other choice walks another simplex there
    for a, b in [(0, 1), (1, 2), (0, 2)]:
        tied = points[:2000].copy()
        tied[:, b] = tied[:, a]
        assert np.abs(sim.noise_at(tied) - noise_numpy(tied, sim.T)).max() < 1e-6, (a, b)
    W = sim.lattice()
    assert np.abs(W - lattice_numpy(30, sim.T)).max() < 1e-6
    # simplex vertices (x + y + z divisible by 3) are corners of their simplex: every corner term is 0 there
    z, y, x = np.indices(W.shape)
    assert (W[(x + y + z) % 3 == 0] == 0).all()
    assert (W != 0).mean() > 0.5 and -0.4 <= W.min() < -0.25 and 0.25 < W.max() <= 0.4  # spec: about [-0.33, 0.34]
    with_random_table = make(runtime, seed=5, L=8, chains=1, noise_T="random")
    assert not np.array_equal(with_random_table.T, sim.T)
    assert np.abs(with_random_table.lattice() - lattice_numpy(8, with_random_table.T)).max() < 1e-6


def test_truncated_density_matches_the_full_sum(runtime, seed):
    sim = make(runtime, L=12, chains=1)
    W = sim.lattice()
    points = np.random.default_rng(seed).uniform(-3, 14, (300, 3)).astype(np.float32)
    full = full_density(W, points)
    assert np.abs(density_numpy(W, points) - full).max() < 1e-9  # the twin: exp(-25) terms left out
    assert np.abs(sim.density_at(points) - full).max() < 3e-6  # float32 nested row sums


def test_grid_density_is_a_trilinear_lookup_of_the_exact_one(runtime, seed):
    sim = make(runtime, L=10, chains=1, density="grid", oversample=4)
    points = np.random.default_rng(seed).uniform(0, 9, (300, 3)).astype(np.float32)
    exact = full_density(sim.lattice(), points)
    # trilinear error <= h^2/8 * sum over axes of max|d2D/dx2|: h = 1/4, measured 0.010; a cell off by one is ~0.1
    assert np.abs(sim.density_at(points) - exact).max() < 0.02
    on_grid = (np.round(points * 4) / 4).astype(np.float32)
    assert np.abs(sim.density_at(on_grid) - full_density(sim.lattice(), on_grid)).max() < 3e-6


def test_legacy_estimator_is_unbiased_for_the_scaled_sum(runtime):
    L, picks = 8, 500
    sim = make(runtime, L=L, chains=1, density="legacy", legacy_picks=picks)
    point = np.array([3.3, 4.1, 2.7], np.float32)
    estimates = sim.density_at(np.tile(point, (2000, 1))).astype(np.float64)  # evaluation i draws chain i's picks
    expected = picks / (L**3 - 1) * full_density(sim.lattice(), point[None])[0]
    error = estimates.std(ddof=1) / np.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error, (estimates.mean(), expected, error)
    assert estimates.std() > 0  # each evaluation is random


# }}}

# {{{ Metropolis


def test_gaussian_target_is_sampled_exactly(runtime):
    p = dict(density="gaussian", L=20, target_mean=(10.0, 10.0, 10.0), target_sigma=2.0, sigma=1.0)
    sim = make(runtime, chains=4096, burn_in=500, samples=1000, **p)
    state = sim.state()
    x = state["samples"].reshape(-1, 3).astype(np.float64)
    # 4e6 correlated states (tau ~ 10): standard error of the mean ~ 0.003, of the variance ~ 0.4 %
    assert np.abs(x.mean(axis=0) - 10.0).max() < 0.05
    assert np.abs(x.var(axis=0) / 4.0 - 1.0).max() < 0.03
    # proposal sigma 1 on a target sigma 2 in 3D: 0.694 (numpy prototype)
    assert 0.67 <= state["acceptance_rate"] <= 0.72


def test_chapter_field_histogram_matches_the_density(runtime):
    # 4096 chains x (200 + 500 steps), every 5th state, take 40 s on 2 PoCL cores; 4096 x (100 + 250),
    # every 2nd state, keep as many (more correlated) samples
    sim = make(runtime, L=12, chains=4096, burn_in=100, samples=250)
    x = sim.state()["samples"][:, ::2].reshape(-1, 3)
    edges = np.linspace(-2.0, 13.0, 7)
    counts, _ = np.histogramdd(x, bins=(edges, edges, edges))
    # normalised max(D, 0) integrated on a 0.125 grid (cell centres), binned the same way
    centres = -2.0 + 0.125 * (np.arange(120) + 0.5)
    e = np.exp(-((centres[:, None] - np.arange(12)) ** 2))  # (120, 12)
    D = np.einsum("ck,bj,ai,kji->abc", e, e, e, sim.lattice().astype(np.float64), optimize=True)  # [x, y, z]
    expected = np.maximum(D, 0.0).reshape(6, 20, 6, 20, 6, 20).sum(axis=(1, 3, 5))
    assert total_variation(counts, expected) < 0.03  # prototype 0.016


def test_threshold_floor_and_reset(runtime):
    sim = make(runtime, L=12, chains=256, burn_in=0, samples=60, threshold=0.1)
    state = sim.state()
    samples = state["samples"]
    moved = np.any(samples != samples[:, :1], axis=2)  # states after the chain's first accepted move
    assert moved.mean() > 0.3
    d = density_numpy(sim.lattice(), samples[moved])
    assert d.min() > 0.1 - 1e-5, d.min()
    ok = state["reset_tries"] < sim.params.reset_limit
    assert ok.all() and (state["init_density"][ok] > 0).all()
    # every change of position is an accepted move
    changes = np.any(np.diff(samples, axis=1) != 0, axis=2).sum(axis=1)
    assert (changes <= state["accepted"]).all()


def test_threshold_is_strict_where_the_density_is_zero(runtime):
    """Next accepts iff (D(x) <= 0 or ...) and D(x') > threshold, strictly: a chain whose Reset found no D > 0 (a
    gaussian target 1e4 away: D = 0 exactly around the start) proposes D(x') = 0 every step, which threshold 0
    refuses and threshold -100 (the book's "off") takes."""
    far = {"density": "gaussian", "target_mean": (1e4, 1e4, 1e4), "target_sigma": 1.0, "reset_limit": 3}
    common = {"L": 8, "chains": 64, "burn_in": 5, "samples": 20, **far}
    for threshold, moves in [(0.0, 0), (-100.0, 25)]:
        state = make(runtime, threshold=threshold, **common).state()
        assert (state["reset_tries"] == 3).all() and (state["init_density"] == 0).all()
        np.testing.assert_array_equal(state["accepted"], moves)
        samples = state["samples"]
        assert np.all(samples == samples[:, :1]) == (moves == 0), threshold


@pytest.mark.parametrize("density", ["exact", "legacy", "grid", "gaussian"])
def test_kernel_trajectories_equal_the_numpy_twin(runtime, density, seed):
    p = Params(L=12, chains=64, burn_in=10, samples=40, density=density, target_mean=(6.0, 6.0, 6.0), legacy_picks=40)
    sim = Simulation(runtime, p, seed)
    state = sim.state()
    grid = sim.grid.get() if density == "grid" else None
    twin = sequence_numpy(p, sim.lattice(), sim.key, np.arange(64), grid=grid)
    close = np.abs(twin["samples"] - state["samples"]).max(axis=(1, 2)) < 1e-4
    assert close.sum() >= 63, f"{(~close).sum()} chains differ"
    np.testing.assert_array_equal(twin["palette"], state["palette"])
    np.testing.assert_array_equal(twin["reset_tries"], state["reset_tries"])
    assert (twin["accepted"] == state["accepted"]).sum() >= 63
    assert state["palette"].max() <= 8 and len(np.unique(state["palette"])) > 5


def test_ring_metropolis_reaches_its_stationary_distribution(seed):
    """Fig 8.1: a Metropolis chain on 8 states of a ring (proposal: a neighbour, each with probability 1/2; the
    code's rule min(1, pi_j / pi_i) >= U) visits state i in proportion to pi_i, and pi is the fixed point of the
    transition matrix P (power iteration from the uniform distribution converges to it; pi P = pi)."""
    pi = np.array([1, 2, 3, 4, 5, 4, 3, 2], np.float64)
    pi /= pi.sum()
    P = np.zeros((8, 8))
    for i in range(8):
        for j in ((i - 1) % 8, (i + 1) % 8):
            P[i, j] = 0.5 * min(1.0, pi[j] / pi[i])
        P[i, i] = 1.0 - P[i].sum()
    v = np.full(8, 1 / 8)
    for _ in range(2000):
        v = v @ P
    np.testing.assert_allclose(v, pi, atol=1e-12)
    np.testing.assert_allclose(pi @ P, pi, atol=1e-15)
    # 4096 chains of 400 steps with Philox draws; every 20th state of the second half (nearly independent)
    chains, steps = 4096, 400
    state = np.zeros(chains, np.int64)
    kept = []
    ids = np.arange(chains, dtype=np.uint32)
    key = np.array([seed & 0xFFFFFFFF, 0], np.uint32)
    for s in range(steps):
        counters = np.column_stack([ids, np.full_like(ids, s), np.zeros_like(ids), np.zeros_like(ids)])
        u = uniform01(philox4x32(counters, key))
        proposal = (state + np.where(u[:, 0] < 0.5, -1, 1)) % 8
        keep = np.minimum(1.0, pi[proposal] / pi[state]) >= u[:, 1]
        state = np.where(keep, proposal, state)
        if s >= steps // 2 and s % 20 == 0:
            kept.append(state.copy())
    counts = np.bincount(np.concatenate(kept), minlength=8)
    assert chi2_pvalue(counts, pi) > 1e-4
    assert chi2_pvalue(counts, np.full(8, 1 / 8)) < 1e-12  # and not the uniform distribution


# }}}

# {{{ rejection and pi


def rejection_twin(sim: Simulation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(candidate u (N, 3), clamped noise v (N,), ids): the draws RejectionSequence makes, recomputed."""
    p = sim.params
    ids = np.arange(p.batches * p.limit, dtype=np.uint32)
    zero = np.zeros_like(ids)
    counters = np.column_stack([ids, zero, zero, np.full_like(ids, PURPOSE_REJECTION)])
    u = uniform01(philox4x32(counters, sim.key))[:, :3]
    v = np.clip(noise_numpy(u * np.float32(p.noise_scale), sim.T), 0.0, 1.0)
    return u, v, ids


def test_rejection_keeps_exactly_the_candidates_above_the_threshold(runtime, seed):
    sim = make(runtime, seed, mode="rejection", L=20, batches=50, limit=1000)
    state = sim.state()
    u, v, ids = rejection_twin(sim)
    tau = np.float32(sim.params.rejection_threshold)
    clear = np.abs(v - tau) >= 1e-5
    np.testing.assert_array_equal(np.intersect1d(state["cand_id"], ids[clear]), ids[clear & (v > tau)])
    assert state["n_accepted"] == len(state["cand_id"]) and state["n_candidates"] == 50000
    np.testing.assert_allclose(state["points"], u[state["cand_id"]] * 20, rtol=1e-6)
    assert (np.diff(state["cand_id"].astype(np.int64)) > 0).all()
    # acceptance fraction within 5 binomial sigma of P(noise > 0.15) on 2e5 independent numpy points
    ref = np.random.default_rng(seed).random((200000, 3)).astype(np.float32) * np.float32(10.0)
    q = (np.clip(noise_numpy(ref, sim.T), 0, 1) > tau).mean()
    n = state["n_candidates"]
    sigma = np.sqrt(q * (1 - q) / n + q * (1 - q) / len(ref))
    assert abs(state["n_accepted"] / n - q) < 5 * sigma, (state["n_accepted"] / n, q)
    # a pool too small: the counter still counts every acceptance, nothing lands beyond the cap
    sim.rejection_sequence(cap=100)
    assert int(sim.counter.get()[0]) == state["n_accepted"]
    points, kept = sim.rejection_points()
    assert len(kept) == 100 and np.isin(kept, state["cand_id"]).all()


def test_rejection_candidates_are_uniform(runtime):
    sim = make(runtime, mode="rejection", L=2, batches=256, limit=1024, rejection_threshold=-1.0)  # keep all
    points = sim.state()["points"]
    assert len(points) == 262144
    counts, _ = np.histogramdd(points, bins=(8, 8, 8), range=[(0, 2)] * 3)
    assert chi2_pvalue(counts, np.ones(512)) > 1e-4


def test_pi_estimate(runtime, seed):
    sim = make(runtime, seed, mode="pi", n=1 << 20)
    _, hits = sim.pi_estimate()
    u, hit = sim.pi_points(1 << 20)  # the twin of every draw: the group sums and atomics lose nothing
    assert hits == int(hit.sum())
    big = make(runtime, seed, mode="pi", n=1 << 24)
    assert abs(big.pi_estimate()[0] - np.pi) < 2e-3  # 5 sigma: 4 sqrt(p (1 - p) / n) = 4e-4
    odd = make(runtime, seed, mode="pi", n=1001)  # a partial last work-item and group
    assert odd.pi_estimate()[1] == int(odd.pi_points(1001)[1].sum())


# }}}

# {{{ parameters, CLI, view


# ranges and cross-field limits: tests/test_params.py checks them for every field of every scene
@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"mode": "gibbs"}, "mode must be one of metropolis\\|rejection\\|pi"),
        ({"correlation": (0.99, 0.99, -0.99)}, "correlation must make a positive definite matrix"),
        ({"threshold": float("inf")}, "threshold must be a finite number"),
    ],
)
def test_bad_parameters_name_the_field_and_range(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_cli_writes_the_spec_arrays(capsys, tmp_path):
    out = tmp_path / "m.npz"
    code, text = run_cli(
        capsys, "run", "mcmc", "--steps", "1", "--set", "L=12", "--set", "chains=64", "--out", str(out)
    )
    assert code == 0, text
    m = np.load(out)
    assert m["lattice_w"].shape == (12, 12, 12) and m["lattice_w"].dtype == np.float32
    assert m["samples"].shape == (64, 20, 3) and m["samples"].dtype == np.float32
    for name, dtype in (("accepted", np.uint32), ("reset_tries", np.uint32), ("palette", np.uint8)):
        assert m[name].shape == (64,) and m[name].dtype == dtype
    assert m["init_density"].dtype == np.float32 and m["noise_T"].dtype == np.int32
    assert m["acceptance_rate"] == m["accepted"].sum() / (64 * 120)
    out = tmp_path / "r.npz"
    code, text = run_cli(capsys, "run", "mcmc_rejection", "--steps", "1", "--set", "batches=10", "--out", str(out))
    assert code == 0, text
    r = np.load(out)
    assert r["n_candidates"] == 10000 and r["n_accepted"] == len(r["cand_id"]) == len(r["points"])
    out = tmp_path / "p.npz"
    code, text = run_cli(
        capsys, "run", "mcmc", "--steps", "1", "--set", "mode=pi", "--set", "n=65536", "--out", str(out)
    )
    assert code == 0, text
    p = np.load(out)
    assert p["n"] == 65536 and p["pi_estimate"] == 4 * p["hits"] / 65536


@pytest.mark.gl
def test_view_draws_a_cube_per_revealed_state(runtime, gl):
    sim = make(runtime, L=12, chains=40, samples=10, chains_per_second=10.0)
    sim.step(1.0)  # the sample's 10 chains per second: 11 chains shown after a second
    pixels, primitives, view, camera = render_view(gl, "mcmc", sim, show_box=False)
    assert primitives == 12 * 11 * 10, "one cube (12 triangles) per emitted state of the revealed chains"
    mask = foreground(pixels, view.background)
    positions = sim.state()["samples"][:11].reshape(-1, 3)
    clip = (camera.projection() @ camera.view() @ np.column_stack([positions, np.ones(len(positions))]).T).T
    ndc = clip[:, :2] / clip[:, 3:]
    px = np.round((ndc[:, 0] + 1) / 2 * 160 - 0.5).astype(int)
    py = np.round((1 - ndc[:, 1]) / 2 * 120 - 0.5).astype(int)
    inside = (px >= 0) & (px < 160) & (py >= 0) & (py < 120)
    assert inside.mean() > 0.9 and mask[py[inside], px[inside]].mean() > 0.95
    # the slice adds translucent colour over the lattice
    sliced, _, _, _ = render_view(gl, "mcmc", sim, show_slice=True, show_box=False)
    assert (foreground(sliced, view.background) & ~mask).mean() > 0.05


@pytest.mark.gl
def test_rejection_view_and_keys(runtime, gl):
    from ugpcl.registry import get

    sim = get("mcmc_rejection").create(runtime, batches=20, limit=500, batches_per_second=1e6)
    sim.step()  # every batch revealed
    pixels, primitives, view, _ = render_view(gl, "mcmc_rejection", sim, show_box=False)
    assert primitives == 12 * int(sim.counter.get()[0]) and foreground(pixels, view.background).mean() > 0.01
    view.next_mode()
    assert sim.params.mode == "pi" and "pi ~" in view.status()[0]
    view.next_mode()
    view.threshold_up()
    assert sim.params.mode == "metropolis" and sim.params.threshold == 0.0
    view.narrower()
    assert sim.params.sigma == pytest.approx(0.8)
    view.next_density()
    assert sim.params.density == "legacy" and "acceptance" in view.status()[1]


# }}}


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind, seed):
    for density in ("exact", "legacy", "grid", "gaussian"):
        p = Params(L=4, chains=5, burn_in=2, samples=3, density=density, legacy_picks=6, oversample=1)
        sim = Simulation(oclgrind, p, seed)  # Prepare, DensityGrid (grid), Sequence
        twin = sequence_numpy(
            p, sim.lattice(), sim.key, np.arange(5), grid=sim.grid.get() if sim.grid is not None else None
        )
        assert (np.abs(twin["samples"] - sim.state()["samples"]).max(axis=(1, 2)) < 1e-4).sum() >= 4
        sim.density_at(np.array([[1.5, 2.0, 0.5]], np.float32))
    sim.noise_at(np.array([[0.5, -1.5, 2.25], [3.0, 3.0, 3.0]], np.float32))
    rejection = Simulation(oclgrind, Params(mode="rejection", L=4, batches=2, limit=40, rejection_threshold=0.0), seed)
    assert rejection.state()["n_accepted"] > 0
    pi = Simulation(oclgrind, Params(mode="pi", n=300), seed)
    assert pi.pi_estimate()[1] == int(pi.pi_points(300)[1].sum())
