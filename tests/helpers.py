"""Small helpers several test modules share (importable because pytest puts tests/ on sys.path)."""

from __future__ import annotations

import numpy as np


def foreground(pixels: np.ndarray, background, tolerance: int = 12) -> np.ndarray:
    """Boolean mask of pixels that differ from the background colour (floats in [0, 1]) by more than tolerance."""
    bg = np.round(np.asarray(background) * 255).astype(int)
    return np.abs(pixels.astype(int) - bg).sum(axis=-1) > tolerance


def first_mismatch(actual: np.ndarray, expected: np.ndarray, rtol: float, atol: float) -> str:
    """Where an allclose check fails first: index, value and expected value (for assertion messages)."""
    bad = ~np.isclose(actual, expected, rtol=rtol, atol=atol)
    if not bad.any():
        return "all close"
    index = np.argwhere(bad)[0]
    row = index[0]
    return f"{bad.sum()} mismatches; first at {tuple(index)}: got {actual[row]}, expected {expected[row]}"
