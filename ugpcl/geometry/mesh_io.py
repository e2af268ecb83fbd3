"""Writing meshes for other tools (``ugpcl run --mesh``): Wavefront OBJ, binary PLY and glTF binary (.glb).

What each format keeps of a ``Mesh`` and of the line segments some scenes export (space colonization skeletons):

=======  =========  =======  =====  ====================================================================
suffix   triangles  normals  uvs    line segments
=======  =========  =======  =====  ====================================================================
.obj     yes        yes      yes    ``l a b`` records
.ply     yes        yes      yes    no: ValueError (PLY readers know no standard edge element)
.glb     yes        yes      yes    mesh "lines": GL_LINES, two vertices per segment, beside mesh "triangles"
=======  =========  =======  =====  ====================================================================

Only .glb embeds ``Mesh.texture`` (as the base colour of the triangles' material).

.glb goes through trimesh; ``trimesh.load`` reads GL_LINES back as one polyline through all the vertices (Blender
and three.js draw the segments).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .mesh import Mesh

MESH_SUFFIXES = (".obj", ".ply", ".glb")
"""The formats ``write_mesh`` writes, by file extension (``--mesh``)."""


class NonFinite(ValueError):
    """An output would hold NaN or inf: refused before anything is written (one line, exit 1)."""


def write_mesh(path, mesh: Mesh, lines=None) -> None:
    """Write ``mesh`` (and ``lines``: (L, 2) indices into ``mesh.vertices``) in the format its suffix names."""
    path = Path(path)
    suffix = path.suffix.lower()
    lines = np.zeros((0, 2), np.int64) if lines is None else np.asarray(lines, np.int64).reshape(-1, 2)
    if len(lines) and (lines.min() < 0 or lines.max() >= len(mesh.vertices)):
        raise ValueError(f"lines must index 0..{len(mesh.vertices) - 1}, got {lines.min()}..{lines.max()}")
    if suffix not in MESH_SUFFIXES:
        raise ValueError(f"--mesh must end in {' or '.join(MESH_SUFFIXES)}, got {str(path)!r}")
    attributes = {"vertices": mesh.vertices, "normals": mesh.normals, "uvs": mesh.uvs}
    bad = [name for name, values in attributes.items() if values is not None and not np.isfinite(values).all()]
    if bad:
        raise NonFinite(f"mesh {' and '.join(bad)} hold NaN or inf")
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".obj":
        _write_obj(path, mesh, lines)
    elif suffix == ".ply":
        if len(lines):
            raise ValueError(f"--mesh {path}: PLY holds triangles only; use .obj or .glb for line segments")
        _write_ply(path, mesh)
    else:
        _write_glb(path, mesh, lines)


OBJ_CORNER = {(False, False): "%d", (True, False): "%d/%d", (False, True): "%d//%d", (True, True): "%d/%d/%d"}
"""An OBJ face corner by (has uvs, has normals): v, v/vt, v//vn, v/vt/vn."""


def _write_obj(path: Path, mesh: Mesh, lines) -> None:
    """OBJ with ``v`` (``vt``, ``vn``) per vertex, ``f`` per triangle, ``l`` per segment (OBJ counts from 1)."""
    with path.open("w") as f:
        f.write(f"# ugpcl: {len(mesh.vertices)} vertices, {len(mesh.faces)} triangles\n")
        np.savetxt(f, mesh.vertices, fmt="v %.6f %.6f %.6f")
        if mesh.uvs is not None:
            np.savetxt(f, mesh.uvs, fmt="vt %.6f %.6f")
        if mesh.normals is not None:
            np.savetxt(f, mesh.normals, fmt="vn %.6f %.6f %.6f")
        if len(mesh.faces):
            # One index per attribute the file has, all the same vertex number.
            corner = OBJ_CORNER[mesh.uvs is not None, mesh.normals is not None]
            faces = np.repeat(mesh.faces.astype(np.int64) + 1, corner.count("%d"), axis=1)
            np.savetxt(f, faces, fmt="f " + " ".join([corner] * 3))
        if len(lines):
            np.savetxt(f, lines + 1, fmt="l %d %d")


def _write_ply(path: Path, mesh: Mesh) -> None:
    """Binary little-endian PLY: float32 x y z (nx ny nz) (s t) per vertex, int32 triangle indices."""
    names = ["x", "y", "z"]
    columns = [mesh.vertices]
    if mesh.normals is not None:
        names += ["nx", "ny", "nz"]
        columns.append(mesh.normals)
    if mesh.uvs is not None:
        names += ["s", "t"]
        columns.append(mesh.uvs)
    vertex_data = np.ascontiguousarray(np.concatenate(columns, axis=1), "<f4")
    face_data = np.empty(len(mesh.faces), [("n", "u1"), ("i", "<i4", 3)])
    face_data["n"], face_data["i"] = 3, mesh.faces
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(mesh.vertices)}"]
    header += [f"property float {name}" for name in names]
    header += [f"element face {len(mesh.faces)}", "property list uchar int vertex_indices", "end_header"]
    with path.open("wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(vertex_data.tobytes())
        f.write(face_data.tobytes())


def _write_glb(path: Path, mesh: Mesh, lines) -> None:
    """glTF binary through trimesh: the triangles as one mesh (normals, uvs as given, nothing merged or
    reordered), the segments as a GL_LINES primitive. Readers: Blender, three.js, ``trimesh.load``."""
    import trimesh
    from PIL import Image
    from trimesh.path.entities import Line

    scene = trimesh.Scene()
    if len(mesh.faces) or not len(lines):  # an empty mesh still makes a valid (empty) file
        visual = None
        if mesh.uvs is not None:
            image = None if mesh.texture is None else Image.fromarray(mesh.texture)
            visual = trimesh.visual.TextureVisuals(uv=mesh.uvs, image=image)
        triangles = trimesh.Trimesh(
            mesh.vertices, mesh.faces, vertex_normals=mesh.normals, visual=visual, process=False
        )
        scene.add_geometry(triangles, geom_name="triangles")
    if len(lines):
        segments = trimesh.path.Path3D([Line(segment) for segment in lines], mesh.vertices, process=False)
        scene.add_geometry(segments, geom_name="lines")
    path.write_bytes(scene.export(file_type="glb"))


def read_ply(path) -> tuple[np.ndarray, np.ndarray]:
    """Read back what ``write_mesh`` wrote to a .ply: (vertices (V, 3), faces (F, 3)); normals and uvs are skipped."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    n_vertices = int(next(h for h in header if h.startswith("element vertex")).split()[-1])
    n_faces = int(next(h for h in header if h.startswith("element face")).split()[-1])
    n_props = sum(h.startswith("property float") for h in header)
    vertices = np.frombuffer(data, "<f4", n_vertices * n_props, end).reshape(n_vertices, n_props)[:, :3]
    faces = np.frombuffer(data, [("n", "u1"), ("i", "<i4", 3)], n_faces, end + n_vertices * n_props * 4)["i"]
    return vertices.copy(), faces.copy()
