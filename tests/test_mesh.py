"""The shared mesh module (ugpcl.geometry.mesh) on shapes with known answers: cube, tetrahedron, open grid."""

from __future__ import annotations

import numpy as np
import pytest

from ugpcl.geometry.mesh import (
    Mesh,
    drop_degenerate,
    face_normals,
    is_watertight,
    normals_agree_with_winding,
    signed_volume,
    triangle_areas,
    vertex_normals,
    weld,
)

# Unit tetrahedron (0, x, y, z), counter-clockwise seen from outside.
TET_VERTICES = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def cube(size=(1.0, 1.0, 1.0), split=False) -> Mesh:
    """Axis-aligned box [0, size], 12 outward triangles. ``split``: each face has its own 4 vertices (24 in all),
    like an export with hard normals, so the faces meet along duplicated seams."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], np.float32) * size
    # Each quad a, b, c, d is counter-clockwise seen from outside: the corner index is 4x + 2y + z.
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    if split:
        vertices, quads = corners[quads.ravel()], np.arange(24).reshape(6, 4)
    else:
        vertices = corners
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return Mesh(vertices, faces)


def grid(n=4) -> Mesh:
    """An open n x n-quad unit square in the z = 0 plane, facing +z, with uvs = (x, y)."""
    xs = np.linspace(0, 1, n + 1)
    x, y = np.meshgrid(xs, xs, indexing="xy")
    vertices = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    i = np.arange(n)[None, :] + (n + 1) * np.arange(n)[:, None]  # lower-left corner of each quad
    a, b, c, d = i.ravel(), i.ravel() + 1, i.ravel() + n + 2, i.ravel() + n + 1
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return Mesh(vertices, faces, uvs=vertices[:, :2])


def test_mesh_coerces_dtypes_and_checks_shapes():
    mesh = Mesh(TET_VERTICES.astype(np.float64), TET_FACES.astype(np.int64))
    assert mesh.vertices.dtype == np.float32 and mesh.faces.dtype == np.int32 and mesh.faces.shape == (4, 3)
    with pytest.raises(ValueError, match="faces must index 0..3"):
        Mesh(TET_VERTICES, TET_FACES + 1)
    with pytest.raises(ValueError, match="normals must have one row per vertex"):
        Mesh(TET_VERTICES, TET_FACES, normals=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="uvs must have one row per vertex"):
        Mesh(TET_VERTICES, TET_FACES, uvs=np.zeros((5, 2)))


def test_tetrahedron_volume_areas_normals():
    mesh = Mesh(TET_VERTICES, TET_FACES)
    assert signed_volume(mesh) == pytest.approx(1 / 6)
    np.testing.assert_allclose(triangle_areas(TET_VERTICES, TET_FACES), [0.5, 0.5, 0.5, np.sqrt(3) / 2])
    expected = [[0, 0, -1], [0, -1, 0], [-1, 0, 0], np.ones(3) / np.sqrt(3)]
    np.testing.assert_allclose(face_normals(TET_VERTICES, TET_FACES), expected, atol=1e-7)
    assert is_watertight(mesh)


def test_vertex_normals_are_area_weighted():
    normals = vertex_normals(TET_VERTICES, TET_FACES)
    # Corner x: faces -z and -y (area 1/2 each) and the slanted face (area sqrt(3)/2, normal (1,1,1)/sqrt(3)).
    # Weighted by area they sum to (1/2, 0, 0); an unweighted mean would point to (0.58, -0.42, -0.42).
    np.testing.assert_allclose(normals[1], [1, 0, 0], atol=1e-7)
    np.testing.assert_allclose(normals[0], -np.ones(3) / np.sqrt(3), atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-6)


@pytest.mark.parametrize("split", [False, True])
def test_cube_volume_and_watertightness(split):
    mesh = cube((1.0, 2.0, 3.0), split)
    assert signed_volume(mesh) == pytest.approx(6.0)
    assert triangle_areas(mesh.vertices, mesh.faces).sum() == pytest.approx(2 * (2 + 3 + 6))
    # The split cube has the right volume but its seams are open: watertight only after welding.
    assert is_watertight(mesh) is not split
    mesh.normals = vertex_normals(mesh.vertices, mesh.faces)
    assert normals_agree_with_winding(mesh) == 1.0


def test_inside_out_cube_has_negative_volume_and_disagreeing_normals():
    mesh = cube()
    outward = vertex_normals(mesh.vertices, mesh.faces)
    inside_out = Mesh(mesh.vertices, mesh.faces[:, ::-1], outward)
    assert signed_volume(inside_out) == pytest.approx(-1.0)
    assert is_watertight(inside_out)  # consistently wound, only the wrong way round
    assert normals_agree_with_winding(inside_out) == 0.0


def test_cube_with_one_flipped_face_fails_the_checks():
    mesh = cube()
    normals = vertex_normals(mesh.vertices, mesh.faces)
    faces = mesh.faces.copy()
    faces[5] = faces[5, ::-1]
    flipped = Mesh(mesh.vertices, faces, normals)
    assert not is_watertight(flipped)  # its three edges now run the same way as their neighbours'
    assert normals_agree_with_winding(flipped) == pytest.approx(11 / 12)
    assert signed_volume(flipped) != pytest.approx(1.0)


def test_cube_missing_a_face_is_not_watertight():
    mesh = cube()
    assert not is_watertight(Mesh(mesh.vertices, mesh.faces[1:]))
    assert not is_watertight(Mesh(mesh.vertices, np.zeros((0, 3))))
    # A triangle used twice makes an edge shared by four faces.
    assert not is_watertight(Mesh(mesh.vertices, np.concatenate([mesh.faces, mesh.faces[:1], mesh.faces[:1, ::-1]])))


def test_open_grid_area_normals_and_boundary():
    mesh = grid(4)
    areas = triangle_areas(mesh.vertices, mesh.faces)
    np.testing.assert_allclose(areas, 1 / 32)
    assert areas.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(face_normals(mesh.vertices, mesh.faces), np.tile([0, 0, 1], (32, 1)), atol=1e-7)
    np.testing.assert_allclose(vertex_normals(mesh.vertices, mesh.faces), np.tile([0, 0, 1], (25, 1)), atol=1e-7)
    assert signed_volume(mesh) == pytest.approx(0.0)
    assert not is_watertight(mesh)


def test_weld_merges_a_split_seam():
    mesh = cube(split=True)
    mesh.normals = np.repeat(face_normals(mesh.vertices, mesh.faces)[:6], 4, axis=0)  # hard normals per face
    mesh.vertices += np.float32(1e-8)  # within tolerance, not bitwise equal after the shift
    welded = weld(mesh, tol=1e-6)
    assert len(welded.vertices) == 8 and len(welded.faces) == 12
    assert is_watertight(welded)
    assert signed_volume(welded) == pytest.approx(1.0)
    # Each corner's normal is the mean of its three faces' normals: the corner direction.
    corner_direction = np.sign(welded.vertices - 0.5) / np.sqrt(3)
    np.testing.assert_allclose(welded.normals, corner_direction, atol=1e-6)
    assert normals_agree_with_winding(welded) == 1.0


def test_weld_keeps_order_drops_collapsed_faces_and_respects_tolerance():
    mesh = grid(2)
    # Two copies of the grid side by side along x share the column x = 1.
    shifted = Mesh(mesh.vertices + [1, 0, 0], mesh.faces, uvs=mesh.uvs)
    both = Mesh.merge([mesh, shifted])
    welded = weld(both)
    assert len(welded.vertices) == 2 * 9 - 3
    np.testing.assert_array_equal(welded.vertices[:9], mesh.vertices)  # first occurrences keep their place
    np.testing.assert_array_equal(welded.uvs[:9], mesh.uvs)
    assert triangle_areas(welded.vertices, welded.faces).sum() == pytest.approx(2.0)
    # Farther apart than the tolerance: nothing merges.
    assert len(weld(Mesh(both.vertices + np.arange(18)[:, None] * 1e-3, both.faces), tol=1e-4).vertices) == 18
    # A sliver whose two corners weld together disappears.
    sliver = Mesh([[0, 0, 0], [1, 0, 0], [1, 1e-9, 0]], [[0, 1, 2]])
    assert len(weld(sliver, tol=1e-6).faces) == 0


def test_weld_merges_across_cell_borders_and_keeps_distinct_vertices_apart(seed):
    tol = 1e-6
    # Each pair straddles a border of the 2 tol cells (at 2e-6 on x, y or z) by 1e-7: one weld for all three.
    border = 2e-6
    vertices = [[border - 1e-7, 0, 0], [border + 1e-7, 0, 0], [5, border - 1e-7, 0], [5, border + 1e-7, 0]]
    vertices += [[9, 9, border - 1e-7], [9, 9, border + 1e-7]]
    assert len(weld(Mesh(np.array(vertices, np.float64), np.zeros((0, 3))), tol).vertices) == 3
    # A chain of vertices 0.9 tol apart spans many cells: it welds whole, into vertex 0 (at the far end of x).
    chain = np.zeros((40, 3))
    chain[:, 0] = 0.9 * tol * np.arange(40)[::-1]
    np.testing.assert_array_equal(weld(Mesh(chain, np.zeros((0, 3))), tol).vertices, chain[:1].astype(np.float32))
    # Brute force on a jittered cloud: any two vertices within tol on every axis end up as one, and the vertices
    # that remain are pairwise more than tol apart on some axis.
    rng = np.random.default_rng(seed)
    points = rng.integers(0, 4, (300, 3)) * 1e-5 + rng.uniform(-0.6, 0.6, (300, 3)) * tol
    welded = weld(Mesh(points, np.zeros((0, 3))), tol)
    kept = welded.vertices.astype(np.float64)
    close = np.all(np.abs(kept[:, None] - kept[None]) <= tol * 0.99, axis=-1)  # 0.99: float32 storage
    assert close.sum() == len(kept)  # only the diagonal
    assert len(kept) == len(np.unique(np.round(points / 1e-5), axis=0))  # one per lattice site
    with pytest.raises(ValueError, match="tol must be > 0"):
        weld(welded, 0.0)
    assert len(weld(Mesh(np.zeros((0, 3)), np.zeros((0, 3)))).vertices) == 0


def test_drop_degenerate_removes_zero_area_triangles_only():
    mesh = cube()
    vertices = np.concatenate([mesh.vertices, [[0, 0, 0.5]]])  # vertex 8: midpoint of the edge 0-1
    faces = np.concatenate([mesh.faces, [[0, 0, 1], [0, 8, 1], [0, 4, 8]]])  # repeated index, collinear, real
    cleaned = drop_degenerate(Mesh(vertices, faces))
    np.testing.assert_array_equal(cleaned.faces, np.concatenate([mesh.faces, [[0, 4, 8]]]))
    np.testing.assert_array_equal(cleaned.vertices, vertices)


def test_merge_offsets_indices_and_keeps_shared_attributes():
    a = grid(1)
    b = Mesh(TET_VERTICES, TET_FACES, vertex_normals(TET_VERTICES, TET_FACES))
    merged = Mesh.merge([b, Mesh(TET_VERTICES + 2, TET_FACES, b.normals)])
    assert signed_volume(merged) == pytest.approx(2 / 6)
    assert is_watertight(merged)
    np.testing.assert_array_equal(merged.faces[4:], TET_FACES + 4)
    np.testing.assert_array_equal(merged.normals, np.concatenate([b.normals, b.normals]))
    mixed = Mesh.merge([a, b])  # a has uvs and no normals, b the other way round
    assert mixed.normals is None and mixed.uvs is None and len(mixed.vertices) == 8
    assert len(Mesh.merge([]).vertices) == 0


def test_normals_agree_needs_normals_and_real_faces():
    with pytest.raises(ValueError, match="needs a mesh with normals"):
        normals_agree_with_winding(Mesh(TET_VERTICES, TET_FACES))
    with pytest.raises(ValueError, match="non-zero area"):
        normals_agree_with_winding(Mesh(TET_VERTICES, [[0, 0, 1]], np.ones((4, 3))))
