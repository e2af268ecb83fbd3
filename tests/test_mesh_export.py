"""``--mesh`` for every scene that makes geometry: each file written (.obj, .ply, .glb) and read back with trimesh
holds the scene's ``mesh()`` (same vertices, faces, normals, uvs), and the geometry itself is right: closed where
the shape is closed, with the analytic volume where there is one, wound the way its normals point."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from helpers import run_cli

from ugpcl.geometry.mesh import (
    Mesh,
    face_normals,
    is_watertight,
    normals_agree_with_winding,
    signed_volume,
    triangle_areas,
    weld,
)
from ugpcl.geometry.mesh_io import MESH_SUFFIXES, write_mesh
from ugpcl.registry import get
from ugpcl.scenes.marching_cubes import field_constants

# scene -> (steps, --set pairs): small sizes for PoCL on shared cores, each still making geometry
CASES = {
    "cloth": (6, ["res=12,10"]),
    "marching_cubes": (1, ["segment_num=32", "animate=false"]),
    "tessellation": (4, ["grid=24", "mesh_level=2"]),
    # masses fixed: on a GPU the nodes' masses follow the atomic append order, so two runs differ in detail
    "space_colonization": (5, ["side=10", "mass_min=1", "mass_max=1"]),
    "grass": (1, ["planes=2,1", "plane_resolution=2"]),
    "grass_pyramid": (1, []),
}


def simulate(runtime, name: str, steps: int, pairs: list[str]):
    """What ``ugpcl run NAME --steps STEPS --set PAIRS`` simulates (seed 0, default dt), through the Python API."""
    scene = get(name)
    overrides = dict(pair.split("=", 1) for pair in pairs)
    params = scene.params(**{k: scene.simulation.Params.parse(k, v) for k, v in overrides.items()})
    sim = scene.simulation(runtime, params, 0)
    for _ in range(steps):
        sim.step()
    return sim


def scene_mesh(name: str, sim) -> Mesh:
    return sim.mesh()


def load(path) -> trimesh.Trimesh | trimesh.Scene:
    return trimesh.load(path, process=False)  # no merging or reordering: the file as written


def loaded_triangles(path) -> trimesh.Trimesh:
    loaded = load(path)
    return loaded.geometry["triangles"] if isinstance(loaded, trimesh.Scene) else loaded


def as_mesh(loaded: trimesh.Trimesh) -> Mesh:
    normals = loaded.vertex_normals if "vertex_normals" in loaded._cache else None  # only if the file had them
    return Mesh(loaded.vertices, loaded.faces, normals)


def assert_same_mesh(path, mesh: Mesh) -> Mesh:
    """The file at ``path`` holds ``mesh``: positions to OBJ's 6 decimals (5e-7), identical faces, normals, uvs."""
    loaded = loaded_triangles(path)
    assert len(loaded.vertices) == len(mesh.vertices), path.name
    np.testing.assert_allclose(loaded.vertices, mesh.vertices, atol=1e-6, err_msg=path.name)
    np.testing.assert_array_equal(loaded.faces, mesh.faces, err_msg=path.name)
    if mesh.normals is not None:
        np.testing.assert_allclose(loaded.vertex_normals, mesh.normals, atol=1e-6, err_msg=path.name)
    if mesh.uvs is not None:
        np.testing.assert_allclose(loaded.visual.uv, mesh.uvs, atol=1e-6, err_msg=path.name)
    return as_mesh(loaded)


# {{{ every scene, every format


@pytest.mark.parametrize("name", CASES)
def test_every_format_holds_the_scene_mesh(runtime, tmp_path, name):
    steps, pairs = CASES[name]
    sim = simulate(runtime, name, steps, pairs)
    mesh = scene_mesh(name, sim)
    assert len(mesh.faces) > 0
    for suffix in MESH_SUFFIXES:
        path = tmp_path / f"{name}{suffix}"
        sim.export_mesh(path)
        loaded = assert_same_mesh(path, mesh)
        if mesh.normals is not None:
            assert normals_agree_with_winding(loaded) == 1.0, path.name


@pytest.mark.parametrize(
    "name, suffix", list(zip(CASES, [".glb", ".ply", ".obj", ".glb", ".ply", ".glb"], strict=True))
)
def test_cli_mesh_option_writes_the_mesh(capsys, runtime, tmp_path, name, suffix):
    steps, pairs = CASES[name]
    path = tmp_path / f"{name}{suffix}"
    sets = [arg for pair in pairs for arg in ("--set", pair)]
    code, text = run_cli(
        capsys, "run", name, "--steps", str(steps), *sets, "--out", str(tmp_path / "a.npz"), "--mesh", str(path)
    )
    assert code == 0, text
    mesh = scene_mesh(name, simulate(runtime, name, steps, pairs))
    loaded = loaded_triangles(path)
    assert (len(loaded.vertices), len(loaded.faces)) == (len(mesh.vertices), len(mesh.faces))


# }}}

# {{{ the geometry of each scene


def marching_cubes_reference_volume(radii, cells_per_unit: int = 200) -> float:
    """Volume where marching_cubes.cl's sphere field exceeds the 0.5 iso value, counted on a fine voxel grid in
    float64 (three spheres on the y axis at 0.25, 0.5, 0.75, joined by log-sum-exp with k = 14 as the kernel does)."""
    h = 1.0 / cells_per_unit
    x = np.arange(0.3, 0.7, h) + h / 2  # the spheres (r <= 0.125, plus the smooth join) stay inside 0.5 +- 0.2
    y = np.arange(0.0, 1.0, h) + h / 2
    px, py, pz = np.meshgrid(x, y, x, indexing="ij", sparse=True)
    field = np.zeros(())
    for i, radius in enumerate(radii):
        sphere = 0.5 - (np.sqrt((px - 0.5) ** 2 + (py - 0.25 - 0.25 * i) ** 2 + (pz - 0.5) ** 2) - radius)
        field = np.logaddexp(14.0 * field, 14.0 * sphere) / 14.0
    return float((field > 0.5).sum() * h**3)


def test_marching_cubes_spheres_are_closed_with_the_field_volume(runtime, tmp_path):
    sim = simulate(runtime, "marching_cubes", *CASES["marching_cubes"])
    sim.export_mesh(tmp_path / "mc.glb")
    mesh = as_mesh(loaded_triangles(tmp_path / "mc.glb"))
    assert is_watertight(mesh)
    assert normals_agree_with_winding(mesh) == 1.0
    expected = marching_cubes_reference_volume(field_constants(sim.params.shape, sim.params.time)[0])
    # Linear interpolation along the cell edges cuts inside the curved surface: the mesh is smaller, by O(h^2)
    # (measured 10 %, 4.5 %, 2.5 % at N = 16, 24, 32); the voxel count itself is good to 0.1 %.
    assert 0.95 * expected < signed_volume(mesh) < expected


def test_cloth_is_one_open_sheet_facing_its_normals(runtime, tmp_path):
    sim = simulate(runtime, "cloth", *CASES["cloth"])
    sim.export_mesh(tmp_path / "cloth.ply")
    mesh = as_mesh(loaded_triangles(tmp_path / "cloth.ply"))
    w, h = sim.width, sim.height
    edges = np.sort(np.concatenate([mesh.faces[:, [0, 1]], mesh.faces[:, [1, 2]], mesh.faces[:, [2, 0]]]), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    assert not is_watertight(mesh) and set(uses.tolist()) == {1, 2}
    assert (uses == 1).sum() == 2 * (w - 1) + 2 * (h - 1)  # the border, once round
    assert normals_agree_with_winding(mesh) == 1.0


def test_tessellation_plane_faces_along_its_normal(runtime, tmp_path):
    from ugpcl.scenes.tessellation import displace_plane_grid

    sim = simulate(runtime, "tessellation", *CASES["tessellation"])
    sim.export_mesh(tmp_path / "t.obj")
    mesh = as_mesh(loaded_triangles(tmp_path / "t.obj"))
    assert sim.density().max() > 0.01  # the brush has displaced something
    plane_normal = displace_plane_grid(sim.density(), 2, 1.0)[2]
    # Displacement tilts the faces by far less than 90 degrees: every face still points along the plane normal.
    assert face_normals(mesh.vertices, mesh.faces) @ plane_normal == pytest.approx(1.0, abs=0.1)
    # A height field's triangles are no smaller than their shadows on the plane: the flat plane's area at least.
    flat, triangles, _ = displace_plane_grid(np.zeros_like(sim.density()), 2, 1.0)
    flat_area = triangle_areas(flat, triangles).sum()
    assert triangle_areas(mesh.vertices, mesh.faces).sum() > flat_area * (1 - 1e-6)
    assert normals_agree_with_winding(mesh) == 1.0


def test_space_colonization_tubes_are_closed_capsules(runtime, tmp_path):
    sim = simulate(runtime, "space_colonization", *CASES["space_colonization"])
    sim.export_mesh(tmp_path / "tubes.glb")
    mesh = as_mesh(loaded_triangles(tmp_path / "tubes.glb"))
    assert is_watertight(mesh) and normals_agree_with_winding(mesh) == 1.0
    a, b = sim.grown_segments()
    length = np.linalg.norm(b - a, axis=1)
    length = length[length > 1e-9]
    r, sides = sim.params.tube_radius, 8
    # Each capsule is a polyhedron inscribed in the round one and holds the 8-sided prism along its edge.
    prism = (sides / 2 * np.sin(2 * np.pi / sides) * r**2 * length).sum()
    capsule = (np.pi * r**2 * length + 4 / 3 * np.pi * r**3).sum()
    assert prism < signed_volume(mesh) < capsule


@pytest.mark.parametrize(
    "name, steps, pairs",
    [
        ("space_colonization", 5, ["side=10", "mesh_kind=lines"]),
        ("space_colonization_cpu", 15, ["crown_points=80,30,5"]),
    ],
)
def test_line_skeletons_go_to_obj_and_glb_not_ply(runtime, tmp_path, name, steps, pairs):
    sim = simulate(runtime, name, steps, pairs)
    if name == "space_colonization":
        a, b = sim.grown_segments()
    else:
        vertices, segments = sim.mesh().vertices, np.asarray(sim.tree.segments).reshape(-1, 2)
        a, b = vertices[segments[:, 0]], vertices[segments[:, 1]]
    assert len(a) > 0
    sim.export_mesh(tmp_path / "tree.obj")
    lines = [line.split() for line in (tmp_path / "tree.obj").read_text().splitlines()]
    vertices = np.array([v[1:] for v in lines if v[0] == "v"], float)
    segments = np.array([v[1:] for v in lines if v[0] == "l"], int) - 1
    np.testing.assert_allclose(vertices[segments[:, 0]], a, atol=1e-5)
    np.testing.assert_allclose(vertices[segments[:, 1]], b, atol=1e-5)
    sim.export_mesh(tmp_path / "tree.glb")
    # GL_LINES: two vertices per segment (trimesh reads them back as one polyline; the vertices are what count).
    path = load(tmp_path / "tree.glb").geometry["lines"]
    np.testing.assert_allclose(path.vertices, np.stack([a, b], axis=1).reshape(-1, 3), atol=1e-5)
    with pytest.raises(ValueError, match="PLY holds triangles only; use .obj or .glb"):
        sim.export_mesh(tmp_path / "tree.ply")


def test_grass_blades_are_consistently_wound_strips(runtime, tmp_path):
    sim = simulate(runtime, "grass", *CASES["grass"])
    sim.export_mesh(tmp_path / "grass.glb")
    mesh = as_mesh(loaded_triangles(tmp_path / "grass.glb"))
    assert len(mesh.vertices) == 7 * sim.blades and len(mesh.faces) == 5 * sim.blades
    # A strip keeps its winding (GL's rule): neighbouring triangles run their shared edge in opposite directions,
    # so no directed edge occurs twice.
    directed = np.concatenate([mesh.faces[:, [0, 1]], mesh.faces[:, [1, 2]], mesh.faces[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed)
    assert (triangle_areas(mesh.vertices, mesh.faces) > 0).all()


def test_grass_pyramids_are_closed_with_base_times_height_over_three(runtime, tmp_path):
    sim = simulate(runtime, "grass_pyramid", *CASES["grass_pyramid"])
    sim.export_mesh(tmp_path / "pyramids.ply")
    mesh = as_mesh(loaded_triangles(tmp_path / "pyramids.ply"))
    model, quad = sim.model, sim.ground
    scale = abs(np.linalg.det(model[:3, :3].astype(np.float64)))  # the model matrix scales every volume
    for k, triangle in enumerate(quad["tri"]):
        one = weld(Mesh(mesh.vertices[12 * k : 12 * k + 12], mesh.faces[4 * k : 4 * k + 4] - 12 * k))
        assert len(one.vertices) == 4 and is_watertight(one)
        base = triangle_areas(quad["pos"], triangle[None])[0]
        assert signed_volume(one) == pytest.approx(base * abs(sim.params.height) / 3 * scale, rel=1e-5)


def test_write_mesh_refuses_unknown_suffixes_and_bad_lines(tmp_path):
    mesh = Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match=r"--mesh must end in .obj or .ply or .glb, got .*m.stl"):
        write_mesh(tmp_path / "m.stl", mesh)
    with pytest.raises(ValueError, match="lines must index 0..2, got 0..3"):
        write_mesh(tmp_path / "m.obj", mesh, lines=[[0, 3]])


# }}}


def test_glb_embeds_the_texture_the_uvs_address(tmp_path):
    """A textured quad: the .glb holds the image as its material's base colour, and v = 0 samples the bottom row."""
    image = np.zeros((4, 8, 3), np.uint8)
    image[0] = (255, 0, 0)  # top row red
    image[-1] = (0, 0, 255)  # bottom row blue
    quad = Mesh(
        [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2), (0, 2, 3)], uvs=[(0, 0), (1, 0), (1, 1), (0, 1)],
        texture=image,
    )  # fmt: skip
    write_mesh(tmp_path / "q.glb", quad)
    loaded = next(iter(trimesh.load(tmp_path / "q.glb").geometry.values()))
    stored = np.asarray(loaded.visual.material.baseColorTexture.convert("RGB"))
    np.testing.assert_array_equal(stored, image)
    np.testing.assert_allclose(loaded.visual.uv, quad.uvs, atol=1e-6)
    assert tuple(loaded.visual.material.to_color(np.array([[0.5, 0.0]]))[0][:3]) == (0, 0, 255)
    with pytest.raises(ValueError, match="texture must be"):
        Mesh(quad.vertices, quad.faces, texture=image)  # a texture needs uvs


def test_the_multiplane_room_carries_its_face_images(runtime, tmp_path):
    """The room's .glb is self-contained: the atlas of the face images, each face's uvs on its own image."""
    scene = get("multiplane_projection")
    sim = scene.create(runtime, 0, face_resolution=(32, 16))
    room = sim.mesh()
    faces = sim.state()["face_images"]
    assert room.texture.shape == (16, 5 * 32, 4)
    np.testing.assert_array_equal(room.texture[::-1, 64:96], faces[2])  # face 2, bottom row first again
    write_mesh(tmp_path / "room.glb", room)
    loaded = next(iter(trimesh.load(tmp_path / "room.glb").geometry.values()))
    assert loaded.visual.material.baseColorTexture.size == (5 * 32, 16)
