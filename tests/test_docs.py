"""Generated documentation stays in step with the code (key tables, parameter tables, scene list)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import foreground
from PIL import Image

from ugpcl.docs import PREVIEW_SIZE, ROOT, tables
from ugpcl.geometry.mesh import Mesh
from ugpcl.geometry.mesh_io import read_ply, write_mesh
from ugpcl.scenes import scenes


def test_generated_tables_are_up_to_date(capsys):
    assert tables(check=True) == 0, capsys.readouterr().out


@pytest.mark.parametrize("name", list(scenes()))
def test_preview_picture_shows_the_scene(name):
    """docs/img/<scene>.png (make png) is there at the preview size and is not an empty frame: more than 0.3 % of
    its pixels differ from its most common colour, which is the background wherever a picture is mostly empty
    (the L-system's one-pixel lines on white, the sparsest picture, cover 0.5 %)."""
    path = ROOT / "docs" / "img" / f"{name}.png"
    assert path.exists(), f"{path.name} missing: run make png"
    with Image.open(path) as image:
        assert image.size == PREVIEW_SIZE, f"{path.name} is {image.size}, run make png"
        pixels = np.asarray(image.convert("RGB"))
    colours, counts = np.unique(pixels.reshape(-1, 3), axis=0, return_counts=True)
    background = colours[counts.argmax()]
    share = foreground(pixels, background / 255.0).mean()
    assert share > 0.003, f"{path.name}: only {share:.1%} of the pixels differ from the background {background}"


def test_mesh_files_round_trip(tmp_path):
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    write_mesh(tmp_path / "t.ply", Mesh(vertices, faces, normals=vertices))
    v, f = read_ply(tmp_path / "t.ply")
    np.testing.assert_array_equal(v, vertices)
    np.testing.assert_array_equal(f, faces)
    write_mesh(tmp_path / "t.obj", Mesh(vertices, faces), lines=[[0, 1]])
    text = (tmp_path / "t.obj").read_text().splitlines()
    assert sum(t.startswith("v ") for t in text) == 4 and "f 1 3 2" in text and "l 1 2" in text
