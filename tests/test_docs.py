"""Generated documentation stays in step with the code (key tables, parameter tables, scene list)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import judge_picture
from PIL import Image

from ugpcl.docs import PREVIEW_SIZE, ROOT, tables
from ugpcl.geometry.mesh import Mesh
from ugpcl.geometry.mesh_io import read_ply, write_mesh
from ugpcl.registry import scenes


def test_generated_tables_are_up_to_date(capsys):
    assert tables(check=True) == 0, capsys.readouterr().out


@pytest.mark.parametrize("name", list(scenes()))
def test_preview_picture_shows_the_scene(name):
    """docs/img/<scene>.png (make png) is there at the preview size and shows its subject as a person would want to
    see it: large enough and whole, its bounding box clear of the frame's edge, as the scene's ``preview_check``
    says."""
    path = ROOT / "docs" / "img" / f"{name}.png"
    assert path.exists(), f"{path.name} missing: run make png"
    with Image.open(path) as image:
        assert image.size == PREVIEW_SIZE, f"{path.name} is {image.size}, run make png"
        pixels = np.asarray(image.convert("RGB"))
    judge_picture(pixels, scenes()[name].preview_check, path.name)


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
