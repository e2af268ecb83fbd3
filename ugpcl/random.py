"""Philox-4x32-10 in numpy: the bit-exact twin of ``philox4x32_10`` and ``uniform01`` in clkernels/include/random.h.

Salmon, Moraes, Dror and Shaw, "Parallel random numbers: as easy as 1, 2, 3" (SC'11; the Random123 library). A
counter-based generator is a keyed bijection: ``philox4x32(counter, key)`` maps each 128-bit counter (four uint32)
to four uint32 that look independent, so a kernel draws the numbers of (item, step, ...) by putting them in the
counter and the seed in the key, and the host recomputes any of them here, bit for bit, to check it.
"""

from __future__ import annotations

import numpy as np

PHILOX_M0 = np.uint64(0xD2511F53)
"""Round multipliers (Random123: PHILOX_M4x32_0, PHILOX_M4x32_1)."""
PHILOX_M1 = np.uint64(0xCD9E8D57)
PHILOX_W0 = np.uint32(0x9E3779B9)
"""Key schedule (Weyl) increments: the golden ratio and sqrt(3) - 1, times 2^32."""
PHILOX_W1 = np.uint32(0xBB67AE85)
ROUNDS = 10

_LOW = np.uint64(0xFFFFFFFF)
_32 = np.uint64(32)


def philox4x32(counter, key) -> np.ndarray:
    """Philox-4x32-10 of each row of ``counter`` ((n, 4) or (4,) uint32) under ``key`` ((2,) uint32).

    Returns uint32 of the counter's shape."""
    c = np.asarray(counter, dtype=np.uint32)
    k = np.asarray(key, dtype=np.uint32)
    if c.shape[-1:] != (4,) or k.shape != (2,):
        raise ValueError(f"philox4x32: counter must be (..., 4) and key (2,), got {c.shape} and {k.shape}")
    x0, x1, x2, x3 = (c[..., i].astype(np.uint64) for i in range(4))
    k0, k1 = np.uint64(k[0]), np.uint64(k[1])
    for r in range(ROUNDS):
        if r > 0:  # the key is bumped between rounds, mod 2^32
            k0 = (k0 + np.uint64(PHILOX_W0)) & _LOW
            k1 = (k1 + np.uint64(PHILOX_W1)) & _LOW
        p0 = PHILOX_M0 * x0  # exact 32 x 32 -> 64-bit products
        p1 = PHILOX_M1 * x2
        x0, x1, x2, x3 = (p1 >> _32) ^ x1 ^ k0, p1 & _LOW, (p0 >> _32) ^ x3 ^ k1, p0 & _LOW
    return np.stack([x0, x1, x2, x3], axis=-1).astype(np.uint32)


def uniform01(bits) -> np.ndarray:
    """Floats in [0, 1) from uint32: (x >> 8) * 2^-24, exact in float32 (random.h: uniform01)."""
    x = np.asarray(bits, dtype=np.uint32)
    return (x >> np.uint32(8)).astype(np.float32) * np.float32(2.0**-24)


def key_of_seed(seed: int) -> np.ndarray:
    """A Philox key from a seed in [0, 2^64): (low 32 bits, high 32 bits), the uint2 a kernel takes."""
    if not 0 <= seed < 2**64:
        raise ValueError(f"seed must be in [0, 2^64), got {seed}")
    return np.array([seed & 0xFFFFFFFF, seed >> 32], dtype=np.uint32)
