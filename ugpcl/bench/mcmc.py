"""``ugpcl bench mcmc``: Sequence per density mode (chain-steps/s, effective samples/s) beside emcee's ensemble
sampler, and the flop counts of a chain step (vol.1 ch.8)."""

from __future__ import annotations

import logging
import time

import numpy as np

from ..scenes.mcmc import DENSITY_MODES, MAX_STATES, Params, Simulation
from .timing import seconds_per_call

STEP_FLOPS = 45
"""One Next step of Sequence besides its density: three box_muller (10 each: two uniform_open01 of 2, log, the
-2 factor, sqrt, the 2 pi factor, sin and the product), the proposal Lc z (9), cur + step (3), the ratio (1) and the
acceptance uniform (2). Flop convention of the benches: an FMA is 2, sqrt, log, exp, sin and a division 1 each,
compares and integer work 0: the Philox draws (two per step, 10 rounds of 32-bit multiplies) are not counted, so
the cheap modes (gaussian, grid) read low against an FP32 peak."""

DENSITY_FLOPS = {"exact": 1728, "grid": 30, "gaussian": 12}
"""One density evaluation per mode. exact (density_exact at an interior point, a mean over uniform positions):
33 exps with their squares (3 each for x, y; 2 plus exp and the sum's FMA for z), a dyz2 sum per (j, k) row tried,
and for the ~78 rows inside the ball the chord (sqrt and 4 more) and plane FMA, and an FMA per lattice point in the
ball (~524); grid: the trilinear lookup (6 to scale, 3 for t, 7 mixes of 3); gaussian: d, dot, 2 sigma^2, the
division and exp. legacy: LEGACY_PICK_FLOPS per pick."""

LEGACY_PICK_FLOPS = 13
"""One pick of density_legacy: the uniform and its scale (2), x - p (3), the dot (5), exp, the weight and the sum."""


def step_flops(p: Params) -> int:
    """Flops of one chain step of Sequence in mode p.density (STEP_FLOPS + one density)."""
    density = LEGACY_PICK_FLOPS * p.legacy_picks if p.density == "legacy" else DENSITY_FLOPS[p.density]
    return STEP_FLOPS + density


def bench(runtime, sizes=None) -> list[dict]:
    """Sequence per density mode: chain-steps/s (burn-in + emitted steps of every chain) and effective samples per
    second (emitted states / integrated autocorrelation time, emcee's estimator averaged over x, y, z), for C chains
    x 1000 steps (PoCL: 100), beside emcee's ensemble sampler (vectorised log-probability) on the same gaussian
    target, where emcee is installed; chain-step flop/s = step_flops per chain-step per second (emcee: -)."""
    try:
        import emcee
    except ImportError:
        emcee = None
    sizes = sizes or ([10**4, 10**5] if runtime.is_gpu else [10**4])
    steps = 1000 if runtime.is_gpu else 100
    burn_in = steps // 10
    rows = []
    for chains in sizes:
        emitted = min(steps, MAX_STATES // chains)  # the samples buffer holds chains x samples states
        for density in DENSITY_MODES:
            lattice = {"L": 20} if density == "gaussian" else {"L": 30}
            p = Params(chains=chains, burn_in=emitted // 10, samples=emitted, density=density, **lattice)
            sim = Simulation(runtime, p, seed=0)
            seconds = seconds_per_call(sim.sequence, runtime.queue, min_seconds=0.5, max_calls=5)
            samples = sim.samples_buffer.get()
            tau = _integrated_time(np.swapaxes(samples, 0, 1)) if emcee else float("nan")
            rows.append(
                {
                    "sampler": "ugpcl Sequence",
                    "density": density,
                    "chains": chains,
                    "steps": p.burn_in + emitted,
                    "ms": seconds * 1e3,
                    "chain-steps/s": chains * (p.burn_in + emitted) / seconds,
                    "tau": tau,
                    "ESS/s": chains * emitted / tau / seconds,
                    "chain-step flop/s": step_flops(p) * chains * (p.burn_in + emitted) / seconds,
                }
            )
    if emcee is not None:
        p = Params(density="gaussian")
        mean, var = np.asarray(p.target_mean), p.target_sigma**2

        def log_prob(x):
            return -((x - mean) ** 2).sum(axis=-1) / (2 * var)

        walkers, emcee_steps = 64, 20 * steps
        start = mean + np.random.default_rng(0).normal(size=(walkers, 3))
        sampler = emcee.EnsembleSampler(walkers, 3, log_prob, vectorize=True)
        begin = time.perf_counter()
        sampler.run_mcmc(start, emcee_steps + burn_in * 20)
        seconds = time.perf_counter() - begin
        chain = sampler.get_chain(discard=burn_in * 20)
        tau = _integrated_time(chain)
        rows.append(
            {
                "sampler": f"emcee {emcee.__version__}",
                "density": "gaussian",
                "chains": walkers,
                "steps": emcee_steps + burn_in * 20,
                "ms": seconds * 1e3,
                "chain-steps/s": walkers * (emcee_steps + burn_in * 20) / seconds,
                "tau": tau,
                "ESS/s": walkers * emcee_steps / tau / seconds,
                "chain-step flop/s": "-",
            }
        )
    return rows


def _integrated_time(x: np.ndarray) -> float:
    """Mean integrated autocorrelation time over the coordinates of x (steps, walkers, dims), emcee's estimator."""
    from emcee.autocorr import integrated_time

    logging.getLogger("emcee").setLevel(logging.ERROR)  # short chains: "chain shorter than 50 tau" is expected
    moving = x.std(axis=0).min(axis=1) > 0  # a walker that never moved has no autocorrelation (legacy: many)
    if not moving.any():
        return float("inf")
    return float(np.mean(integrated_time(x[:, moving], quiet=True)))
