"""Generated documentation stays in step with the code (key tables, parameter tables, scene list)."""

from __future__ import annotations

import numpy as np

from ugpcl.docs import tables
from ugpcl.geometry.mesh import Mesh
from ugpcl.geometry.mesh_io import read_ply, write_mesh


def test_generated_tables_are_up_to_date(capsys):
    assert tables(check=True) == 0, capsys.readouterr().out


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
