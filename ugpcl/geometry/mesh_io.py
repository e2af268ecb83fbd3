"""Writing meshes for other tools: Wavefront OBJ (triangles and/or line segments) and binary PLY (triangles)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_obj(path, vertices, faces=None, normals=None, lines=None) -> None:
    """OBJ with ``v`` (and ``vn``) per vertex, ``f`` per triangle, ``l`` per segment; indices are 0-based here."""
    vertices = np.asarray(vertices, np.float64).reshape(-1, 3)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w") as f:
        f.write(f"# ugpcl: {len(vertices)} vertices\n")
        np.savetxt(f, vertices, fmt="v %.6f %.6f %.6f")
        if normals is not None:
            np.savetxt(f, np.asarray(normals, np.float64).reshape(-1, 3), fmt="vn %.6f %.6f %.6f")
        if faces is not None and len(faces):
            faces = np.asarray(faces, np.int64).reshape(-1, 3) + 1
            fmt = "f %d//%d %d//%d %d//%d" if normals is not None else "f %d %d %d"
            np.savetxt(f, np.repeat(faces, 2, axis=1) if normals is not None else faces, fmt=fmt)
        if lines is not None and len(lines):
            np.savetxt(f, np.asarray(lines, np.int64).reshape(-1, 2) + 1, fmt="l %d %d")


def write_ply(path, vertices, faces, normals=None) -> None:
    """Binary little-endian PLY with float32 positions (and normals) and int32 triangle indices."""
    vertices = np.asarray(vertices, np.float32).reshape(-1, 3)
    faces = np.asarray(faces, np.int32).reshape(-1, 3)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if normals is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    vertex_data = np.empty(len(vertices), fields)
    vertex_data["x"], vertex_data["y"], vertex_data["z"] = vertices.T
    if normals is not None:
        vertex_data["nx"], vertex_data["ny"], vertex_data["nz"] = np.asarray(normals, np.float32).reshape(-1, 3).T
    face_data = np.empty(len(faces), [("n", "u1"), ("i", "<i4", 3)])
    face_data["n"], face_data["i"] = 3, faces
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(vertices)}"]
    header += [f"property float {name}" for name, _ in fields]
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(vertex_data.tobytes())
        f.write(face_data.tobytes())


def read_ply(path) -> tuple[np.ndarray, np.ndarray]:
    """Read back what ``write_ply`` wrote: (vertices (V, 3), faces (F, 3)); normals are skipped."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    n_vertices = int(next(h for h in header if h.startswith("element vertex")).split()[-1])
    n_faces = int(next(h for h in header if h.startswith("element face")).split()[-1])
    n_props = sum(h.startswith("property float") for h in header)
    vertices = np.frombuffer(data, "<f4", n_vertices * n_props, end).reshape(n_vertices, n_props)[:, :3]
    faces = np.frombuffer(data, [("n", "u1"), ("i", "<i4", 3)], n_faces, end + n_vertices * n_props * 4)["i"]
    return vertices.copy(), faces.copy()


MESH_SUFFIXES = (".obj", ".ply")
"""The formats ``write_mesh`` writes, by file extension (``--mesh``)."""


def write_mesh(path, vertices, faces=None, normals=None, lines=None) -> None:
    """By extension: ``.obj`` (triangles and/or lines) or ``.ply`` (triangles)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".obj":
        write_obj(path, vertices, faces, normals, lines)
    elif suffix == ".ply":
        if faces is None:
            raise ValueError(f"--mesh {path}: PLY needs triangles; use .obj for line segments")
        write_ply(path, vertices, faces, normals)
    else:
        raise ValueError(f"--mesh must end in .obj or .ply, got {path!r}")
