"""Damaged and hostile files for every scene parameter that names a file (ear_clipping's rings, star_glow's image),
run the way the CLI runs them: each either runs (exit 0, finite outputs) or exits 2 with exactly one line that
names the parameter; never a traceback, never exit 1. The readers' own cases are in test_ear_clipping.py and
test_star_glow.py; the checks live in ugpcl/inputs.py and ugpcl/geometry/ear_clipping_input.py."""

from __future__ import annotations

import io
import json
import struct
import tempfile
import zlib
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ugpcl.cli import main
from ugpcl.geometry.ear_clipping_input import PRESETS

FUZZ = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
"""About 20 s for the whole module on PoCL: most cases stop at the parameter check, before any kernel."""


def run(scene: str, name: str, data: bytes) -> None:
    """``ugpcl run SCENE --set input=FILE`` with ``data`` in FILE (named ``name``): exit 0 with finite arrays, or
    exit 2 with one line naming ``input``."""
    with tempfile.TemporaryDirectory() as folder:
        path, out = Path(folder) / name, Path(folder) / "out.npz"
        path.write_bytes(data)
        err = io.StringIO()
        with redirect_stderr(err), redirect_stdout(io.StringIO()):
            code = main(["run", scene, "--set", f"input={path}", "--steps", "1", "--quiet", "--out", str(out)])
        lines = err.getvalue().splitlines()
        if code == 0:
            with np.load(out) as saved:
                for key in saved.files:
                    if saved[key].dtype.kind == "f":
                        assert np.isfinite(saved[key]).all(), key
        else:
            assert code == 2, err.getvalue()
            assert len(lines) == 1 and lines[0].startswith(f"ugpcl: error: input {path}: "), lines


# {{{ ear_clipping input: JSON rings

NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**30), 10**30),
    st.sampled_from([0.0, 1.0, -1.0, 1e9, 1e39, 5e-324, 10**400]),
)
POINTS = st.one_of(st.lists(NUMBERS, min_size=2, max_size=2), st.lists(NUMBERS, max_size=4), NUMBERS, st.none())
JSON = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=5),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from(["rings", "foo", ""]), inner, max_size=3)
    ),
    max_leaves=20,
)


@FUZZ
@given(JSON)
def test_any_json_value(value):
    run("ear_clipping", "rings.json", json.dumps(value).encode())
    run("ear_clipping", "rings.json", json.dumps({"rings": value}).encode())


@FUZZ
@given(st.lists(st.lists(POINTS, max_size=8), min_size=1, max_size=3))
def test_rings_of_hostile_points(rings):
    run("ear_clipping", "rings.json", json.dumps({"rings": rings}).encode())


@FUZZ
@given(st.lists(st.lists(st.tuples(st.integers(-3, 3), st.integers(-3, 3)), min_size=3, max_size=7), max_size=3))
def test_rings_of_small_integer_points(rings):
    """Duplicates, lines, bowties, rings that touch or cross: triangulated whole or refused."""
    run("ear_clipping", "rings.json", json.dumps({"rings": rings}).encode())


VALID_RINGS = json.dumps({"rings": [np.asarray(r).tolist() for r in PRESETS["holes"]()]}, indent=1).encode()


@FUZZ
@given(st.integers(0, len(VALID_RINGS) - 1), st.binary(max_size=3))
def test_truncated_or_overwritten_json(cut, junk):
    run("ear_clipping", "rings.json", VALID_RINGS[:cut] + junk)


@FUZZ
@given(st.binary(max_size=64))
def test_random_bytes_as_json(data):
    run("ear_clipping", "rings.json", data)


# }}}

# {{{ star_glow input: PNG and .npy


def png(width: int, height: int, body: bytes) -> bytes:
    """A PNG whose IHDR declares width x height RGB8 and whose IDAT holds ``body`` compressed."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(body)) + chunk(b"IEND", b"")


def npy(shape: tuple, dtype: str, body: bytes) -> bytes:
    f = io.BytesIO()
    np.lib.format.write_array_header_1_0(f, {"descr": dtype, "fortran_order": False, "shape": shape})
    return f.getvalue() + body


def valid_npy() -> bytes:
    f = io.BytesIO()
    np.save(f, np.linspace(0, 3, 8 * 8 * 3, dtype=np.float32).reshape(8, 8, 3))
    return f.getvalue()


VALID_IMAGES = {".png": png(8, 8, bytes(8 * (1 + 8 * 3))), ".npy": valid_npy()}
DTYPES = ["<f4", "<f8", ">f2", "|u1", "<i8", "|b1", "<c8", "|O", "<U3", "|V8", "<M8[s]"]


@FUZZ
@given(st.sampled_from(sorted(VALID_IMAGES)), st.binary(max_size=200))
def test_random_bytes_as_image(suffix, data):
    run("star_glow", f"image{suffix}", data)


@FUZZ
@given(st.sampled_from(sorted(VALID_IMAGES)), st.data())
def test_truncated_or_corrupted_image(suffix, data):
    valid = VALID_IMAGES[suffix]
    cut = data.draw(st.integers(0, len(valid)))
    flip = data.draw(st.integers(0, len(valid) - 1))
    damaged = bytearray(valid)
    damaged[flip] ^= data.draw(st.integers(1, 255))
    run("star_glow", f"image{suffix}", valid[:cut])
    run("star_glow", f"image{suffix}", bytes(damaged))


SIDES = st.integers(0, 1 << 31)


@FUZZ
@given(SIDES, SIDES, st.binary(max_size=64))
def test_png_declaring_any_size(width, height, body):
    run("star_glow", "image.png", png(width, height, body))


SHAPES = st.one_of(
    st.lists(st.integers(0, 1 << 40), max_size=4).map(tuple),
    st.tuples(st.integers(0, 9), st.integers(0, 9), st.integers(2, 5)),  # image-like: the dtype and length decide
)


@FUZZ
@given(SHAPES, st.sampled_from(DTYPES), st.integers(0, 2000))
def test_npy_declaring_any_shape_and_dtype(shape, dtype, length):
    run("star_glow", "image.npy", npy(shape, dtype, bytes(length)))


# }}}


@pytest.mark.parametrize(
    "scene, name, data",
    [
        ("ear_clipping", "rings.json", VALID_RINGS),
        ("star_glow", "image.png", VALID_IMAGES[".png"]),
        ("star_glow", "image.npy", VALID_IMAGES[".npy"]),
    ],
)
def test_the_valid_files_run(capsys, scene, name, data):
    """The files the fuzz cases damage run as they are (else every case above could pass by refusal)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        path.write_bytes(data)
        assert (
            main(["run", scene, "--set", f"input={path}", "--steps", "1", "--quiet", "--out", f"{folder}/o.npz"]) == 0
        )
