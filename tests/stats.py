"""Statistical checks for samplers (MCMC, Poisson disk, ...): goodness of fit, distances between distributions and
the effective sample size of correlated chains. Each returns a number; the tests choose the bound and say why."""

from __future__ import annotations

import numpy as np
from scipy import stats


def chi2_pvalue(observed, expected) -> float:
    """Pearson's chi-square goodness-of-fit p-value of counts ``observed`` against ``expected`` (any scale: rescaled
    to the same total). Bins with expected count 0 must be empty. Degrees of freedom: bins - 1."""
    observed = np.asarray(observed, np.float64).ravel()
    expected = np.asarray(expected, np.float64).ravel()
    expected = expected * observed.sum() / expected.sum()
    used = expected > 0
    if observed[~used].any():
        return 0.0
    statistic = ((observed[used] - expected[used]) ** 2 / expected[used]).sum()
    return float(stats.chi2.sf(statistic, used.sum() - 1))


def ks_pvalue(samples, cdf="uniform") -> float:
    """One-sample Kolmogorov-Smirnov p-value of ``samples`` against ``cdf`` (a scipy name or a callable)."""
    return float(stats.kstest(np.asarray(samples, np.float64).ravel(), cdf).pvalue)


def total_variation(p, q) -> float:
    """Total variation distance 0.5 * sum |p - q| of two histograms, each normalised to sum 1 first."""
    p = np.asarray(p, np.float64).ravel()
    q = np.asarray(q, np.float64).ravel()
    return float(0.5 * np.abs(p / p.sum() - q / q.sum()).sum())


def integrated_time(chains, window: float = 5.0) -> float:
    """Integrated autocorrelation time tau of ``chains`` (steps,) or (n_chains, steps): the autocorrelation averaged
    over chains (FFT), summed up to Sokal's automatic window M, the first M >= window * tau(M)."""
    x = np.atleast_2d(np.asarray(chains, np.float64))
    n = x.shape[1]
    x = x - x.mean(axis=1, keepdims=True)
    size = 2 ** int(np.ceil(np.log2(2 * n)))
    spectrum = np.fft.rfft(x, size, axis=1)
    acf = np.fft.irfft(spectrum * np.conj(spectrum), size, axis=1)[:, :n].mean(axis=0)
    acf /= acf[0]
    taus = 2.0 * np.cumsum(acf) - 1.0
    m = np.arange(n) >= window * taus
    return float(taus[np.argmax(m)] if m.any() else taus[-1])


def effective_sample_size(chains, window: float = 5.0) -> float:
    """Number of independent samples worth of ``chains`` (steps,) or (n_chains, steps): samples / tau."""
    x = np.atleast_2d(np.asarray(chains))
    return x.size / integrated_time(x, window)
