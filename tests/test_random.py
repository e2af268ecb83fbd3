"""Random numbers (clkernels/include/random.h, clkernels/random.cl, ugpcl/random.py): Philox-4x32-10 against
Random123's known answers, in numpy and on the device, and the device against numpy bit for bit."""

from __future__ import annotations

import numpy as np
import pyopencl.cltypes as cltypes
import pytest

from ugpcl.random import key_of_seed, philox4x32, uniform01

GROUP_SIZE = 64

# Random123's known-answer vectors for philox4x32_R(10, ctr, key) (its kat_vectors file): counter, key, result.
KNOWN_ANSWERS = [
    ((0x00000000, 0x00000000, 0x00000000, 0x00000000), (0x00000000, 0x00000000),
     (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
    ((0xFFFFFFFF, 0xFFFFFFFF, 0xFFFFFFFF, 0xFFFFFFFF), (0xFFFFFFFF, 0xFFFFFFFF),
     (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
    ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
     (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)),
]  # fmt: skip


def philox_fill(rt, counters: np.ndarray, key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PhiloxFill on the device: (bits (n, 4) uint32, uniforms (n, 4) float32) of each counter row under key."""
    n = len(counters)
    bits = rt.empty((n, 4), np.uint32)
    uniforms = rt.empty((n, 4), np.float32)
    rt.program("random").kernel("PhiloxFill").over(
        n,
        GROUP_SIZE,
        rt.to_device(np.ascontiguousarray(counters, dtype=np.uint32)),
        np.int32(n),
        cltypes.make_uint2(*(int(k) for k in key)),
        bits,
        uniforms,
    )
    return bits.get(), uniforms.get()


def random_counters(n: int, seed: int) -> np.ndarray:
    """n counters with every word random, plus the extremes (0 and all ones) as the first two rows."""
    counters = np.random.default_rng(seed).integers(0, 2**32, (n, 4), dtype=np.uint32)
    counters[0], counters[1] = 0, 0xFFFFFFFF
    return counters


def known_answer_arrays() -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    counters = np.array([c for c, _, _ in KNOWN_ANSWERS], np.uint32)
    keys = [np.array(k, np.uint32) for _, k, _ in KNOWN_ANSWERS]
    expected = np.array([r for _, _, r in KNOWN_ANSWERS], np.uint32)
    return counters, keys, expected


def assert_bits_equal(got: np.ndarray, expected: np.ndarray, what: str) -> None:
    bad = np.argwhere(got != expected)
    if len(bad):
        i, j = bad[0]
        raise AssertionError(
            f"{what}: {len(bad)} words differ; first at row {i} word {j}: {got[i, j]:08x}, "
            f"expected {expected[i, j]:08x}"
        )


# {{{ numpy twin


def test_numpy_philox_matches_random123_known_answers():
    counters, keys, expected = known_answer_arrays()
    for counter, key, result in zip(counters, keys, expected, strict=True):
        np.testing.assert_array_equal(philox4x32(counter, key), result)  # a (4,) counter alone
        np.testing.assert_array_equal(philox4x32(counter[None], key)[0], result)  # as a row of (n, 4)


def test_numpy_philox_is_a_keyed_function_of_every_word():
    """Changing any one bit of the counter or key changes about half of the 128 output bits (avalanche)."""
    counters = random_counters(256, 1)
    key = key_of_seed(0x0123456789ABCDEF)
    base = philox4x32(counters, key)
    for word in range(4):
        flipped = counters.copy()
        flipped[:, word] ^= np.uint32(1 << (word * 7))
        changed = np.unpackbits((philox4x32(flipped, key) ^ base).view(np.uint8)).mean()
        assert 0.45 < changed < 0.55, f"counter word {word}: {changed:.3f} of the output bits changed"
    changed = np.unpackbits((philox4x32(counters, key ^ np.uint32(1)) ^ base).view(np.uint8)).mean()
    assert 0.45 < changed < 0.55, f"key bit 0: {changed:.3f} of the output bits changed"


def test_uniform01_is_in_the_unit_interval_and_exact():
    extremes = uniform01(np.array([0, 0xFF, 0x100, 0xFFFFFFFF], np.uint32))
    assert extremes.dtype == np.float32
    # 24-bit steps: 0 and 0xFF give 0, 0x100 the smallest step 2^-24, 0xFFFFFFFF the largest value 1 - 2^-24 < 1
    np.testing.assert_array_equal(extremes, np.array([0.0, 0.0, 2.0**-24, 1.0 - 2.0**-24], np.float32))
    u = uniform01(philox4x32(random_counters(4099, 2), key_of_seed(7)))
    assert u.min() >= 0.0 and u.max() < 1.0
    # mean of 16396 uniforms: standard deviation sqrt(1/12 / 16396) ~ 0.0023; 5 sigma
    assert abs(u.mean() - 0.5) < 0.0115


def test_key_of_seed_splits_the_seed_in_two_words():
    np.testing.assert_array_equal(key_of_seed(0x0123456789ABCDEF), np.array([0x89ABCDEF, 0x01234567], np.uint32))
    with pytest.raises(ValueError, match="seed must be in"):
        key_of_seed(-1)


# }}}

# {{{ device


def test_device_philox_matches_random123_known_answers(runtime):
    counters, keys, expected = known_answer_arrays()
    for i, key in enumerate(keys):
        bits, _ = philox_fill(runtime, counters[i : i + 1], key)
        assert_bits_equal(bits, expected[i : i + 1], f"known answer {i}")


@pytest.mark.parametrize("n", [1, GROUP_SIZE - 1, GROUP_SIZE, GROUP_SIZE + 1, 4099])
def test_device_philox_matches_numpy_bit_for_bit(runtime, n, seed):
    counters = random_counters(n, seed) if n > 1 else np.zeros((1, 4), np.uint32)
    key = key_of_seed(seed)
    bits, uniforms = philox_fill(runtime, counters, key)
    expected = philox4x32(counters, key)
    assert_bits_equal(bits, expected, "bits")
    assert_bits_equal(uniforms.view(np.uint32), uniform01(expected).view(np.uint32), "uniforms (as bits)")
    assert uniforms.min() >= 0.0 and uniforms.max() < 1.0


# }}}


@pytest.mark.oclgrind
def test_philox_on_oclgrind(oclgrind, seed):
    counters = random_counters(67, seed)
    key = key_of_seed(seed)
    bits, uniforms = philox_fill(oclgrind, counters, key)
    expected = philox4x32(counters, key)
    assert_bits_equal(bits, expected, "bits")
    assert_bits_equal(uniforms.view(np.uint32), uniform01(expected).view(np.uint32), "uniforms (as bits)")
    known, keys, answers = known_answer_arrays()
    bits, _ = philox_fill(oclgrind, known[2:3], keys[2])
    assert_bits_equal(bits, answers[2:3], "known answer 2")
