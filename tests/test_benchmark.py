"""The device probes behind `ugpcl bench`: LaunchProbe's result, FmaProbe's arithmetic (so its flop count is real
work), the measured limits and the share columns built from them."""

from __future__ import annotations

import numpy as np
import pytest

from ugpcl.benchmark import DeviceLimits, copy_rate, fp32_rate, with_shares


def fma_probe_reference(n: int, rounds: int, a: float, b: float) -> np.ndarray:
    """FmaProbe in float64: 8 chains x = a x + b per lane, rounds x 16 times, then summed."""
    i = np.arange(n, dtype=np.float64)[:, None]
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


def test_measured_limits_are_positive_and_shares_follow_their_columns(runtime):
    assert copy_rate(runtime, 2**20) > 0 and fp32_rate(runtime) > 0
    limits = DeviceLimits(copy_bytes_per_s=1e9, fp32_flops=1e12)
    rows = with_shares([{"size": 8, "Jacobi bytes/s": 2.5e8, "x flop/s": 5e11, "ms": 1.0}], limits)
    assert list(rows[0]) == ["size", "Jacobi bytes/s", "% copy bw", "x flop/s", "% FP32 peak", "ms"]
    assert rows[0]["% copy bw"] == pytest.approx(25.0) and rows[0]["% FP32 peak"] == pytest.approx(50.0)


@pytest.mark.oclgrind
def test_probes_are_clean_under_oclgrind(oclgrind):
    launch, fma = run_probes(oclgrind, n=16, rounds=1)
    np.testing.assert_allclose(fma, fma_probe_reference(16, 1, 0.999, 1e-3), rtol=1e-5)
