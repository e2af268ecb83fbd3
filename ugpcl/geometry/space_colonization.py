"""Space colonization on the host in numpy (float64): the attraction clouds, the blog's tree and the tube mesh of a
grown tree (Unity Graphics Programming vol.4 ch.1 sections 1.2-1.3 and B. Olij's blog post;
docs/chapters/12-space-colonization.md).

* ``BlogTree``: B. Olij's "Space Colonization Algorithm Part 1" (blog, 2014) as written: vertex 0 at the origin,
  each attraction point remembers its closest vertex and compares only the vertices added since the last iteration,
  kills before it attracts, grows every pulled vertex one normalised ``branch`` step plus a ``bias`` vector.
  ``ugpcl run space_colonization_cpu`` runs it.
* ``sphere_cloud`` (the book's ``GenerateSphereAttractions``), ``hemisphere_cloud`` (the blog's generator),
  ``box_cloud``; ``tube_mesh`` (capsules for ``--mesh``).

The numpy reference of the book's GPU step, which the kernel tests compare against, is
``tests/reference/space_colonization.py``. Both share ugpcl's two guards against the trap the book and the blog both
have (docs/chapters/12-space-colonization.md, "What differs from the book"): opposite attractions cancel, the mean
direction is ~0 and a node regrows the same point forever. ``repeat_guard`` stops a node repeating its last growth;
the blog loop also stops when an iteration grows nothing new.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

MIN_DIRECTION = 1e-12
"""An attraction this close to a node gives no direction (normalize(0) = NaN): skipped, as in the kernels."""
REPEAT_TOLERANCE = 1e-3
"""repeat_guard: a new point within this fraction of the step of the node's last one is a repeat."""


def normalize_rows(v: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(length, 1e-300)


# {{{ attraction clouds


def sphere_cloud(side: int, rng: np.random.Generator) -> np.ndarray:
    """The book's sphere: grid points (x, y, z)/(side - 1) - 0.5 inside radius 0.5, each jittered by
    U(-0.5, 0.5)^3 / (side - 1). side 28 gives 10144 points."""
    g = np.arange(side) / (side - 1) - 0.5
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    p = p[np.sum(p * p, axis=1) < 0.25]
    return p + rng.uniform(-0.5, 0.5, p.shape) / (side - 1)


def box_cloud(side: int, rng: np.random.Generator) -> np.ndarray:
    """side^3 jittered grid points filling the cube [-0.5, 0.5]^3 (ugpcl)."""
    g = np.arange(side) / (side - 1) - 0.5
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    return p + rng.uniform(-0.5, 0.5, p.shape) / (side - 1)


def randf(rng: np.random.Generator, n: int, lo: float = -1.0, hi: float = 1.0) -> np.ndarray:
    """The blog's randf(lo, hi): uniform, quantised to 1e-5 of the range."""
    return lo + (hi - lo) * rng.integers(0, 100001, n) / 100000.0


def hemisphere_cloud(n: int, outer: float, inner: float, aspect: float, offset_y: float, rng) -> np.ndarray:
    """The blog's generateAttractionPoints: direction (randf, randf(0, 1), randf) normalised (not uniform on the
    hemisphere), radius uniform in [inner, outer) (denser inside), y stretched by aspect and raised by offset_y."""
    point = np.column_stack([randf(rng, n), randf(rng, n, 0.0, 1.0), randf(rng, n)])
    point = normalize_rows(point)
    point *= ((outer - inner) * randf(rng, n, 0.0, 1.0) + inner)[:, None]
    point[:, 1] = point[:, 1] * aspect + offset_y
    return point


# }}}

# {{{ the blog's tree


@dataclass
class BlogTree:
    """The blog's ``treelogic``: vertices, segments, attraction points with their closest vertex."""

    vertices: np.ndarray = field(default_factory=lambda: np.zeros((1, 3)))
    segments: list = field(default_factory=list)
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    closest: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    last_num_verts: int = 1
    """Vertices below this index were already compared with every point (the blog's mLastNumOfVerts)."""
    last_growth: dict = field(default_factory=dict)
    """Vertex -> where it grew to last (the repeat guard and the stall detector)."""

    def grow_branch(self, v: int, to) -> int:
        self.vertices = np.vstack([self.vertices, np.asarray(to, float)[None]])
        self.segments.append((v, len(self.vertices) - 1))
        return len(self.vertices) - 1

    def add_points(self, points: np.ndarray, clear: bool = False) -> None:
        """New points start with closest = vertex 0 (as generateAttractionPoints leaves them)."""
        if clear:
            self.points, self.closest = np.zeros((0, 3)), np.zeros(0, np.int64)
        self.points = np.vstack([self.points, points])
        self.closest = np.concatenate([self.closest, np.zeros(len(points), np.int64)])

    def do_iteration(
        self, max_distance: float, branch_size: float, cut_off_distance: float, bias, repeat_guard: bool = False
    ) -> tuple[bool, int, bool]:
        """One doIteration. Returns (points left, vertices grown, every growth repeated the vertex's last one)."""
        num_verts = len(self.vertices)
        v_closest = self.vertices[self.closest]
        current = np.linalg.norm(v_closest - self.points, axis=1)
        new = self.vertices[self.last_num_verts :]
        if len(new) and len(self.points):  # vertices never move: only the new ones can be closer
            d = np.linalg.norm(self.points[:, None, :] - new[None, :, :], axis=2)
            best = d.argmin(axis=1)  # the first minimum: the blog's strict < in vertex order
            closer = d[np.arange(len(d)), best] < current
            self.closest[closer] = self.last_num_verts + best[closer]
            current[closer] = d[closer, best[closer]]
        keep = current >= cut_off_distance  # kill first
        self.points, self.closest, current = self.points[keep], self.closest[keep], current[keep]
        pulled = current < max_distance
        norm = self.points[pulled] - self.vertices[self.closest[pulled]]
        length = np.linalg.norm(norm, axis=1)
        ok = length >= MIN_DIRECTION
        counts = np.bincount(self.closest[pulled][ok], minlength=num_verts).astype(float)
        directions = np.zeros((num_verts, 3))
        np.add.at(directions, self.closest[pulled][ok], norm[ok] / length[ok, None])
        self.last_num_verts = num_verts
        grown, repeated = 0, 0
        for v in np.flatnonzero(counts > 0):
            direction = directions[v] / counts[v]
            size = np.linalg.norm(direction)
            if size < MIN_DIRECTION:  # opposite points cancel exactly: no direction to grow in
                continue
            to = self.vertices[v] + direction / size * branch_size + np.asarray(bias, float)
            last = self.last_growth.get(int(v))
            is_repeat = last is not None and np.linalg.norm(to - last) < REPEAT_TOLERANCE * branch_size
            if is_repeat and repeat_guard:
                continue
            repeated += is_repeat
            self.last_growth[int(v)] = to
            self.grow_branch(int(v), to)
            grown += 1
        return len(self.points) > 0, grown, grown > 0 and repeated == grown


# }}}

# {{{ tubes for --mesh


def edge_frames(direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to each (unit) direction and to each other, independent of any view."""
    helper = np.where(np.abs(direction[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    n = normalize_rows(np.cross(direction, helper))
    return n, np.cross(direction, n)


def tube_mesh(a: np.ndarray, b: np.ndarray, radius: float, sides: int = 8, cap_rows: int = 4):
    """A closed capsule around every segment a -> b (segments shorter than 1e-9 are left out).

    Returns (vertices (V, 3), normals (V, 3), triangles (T, 3)); triangles wind counter-clockwise seen from outside.
    Per segment: one ring at each end, ``cap_rows - 1`` more rings and a pole per hemispherical cap.
    """
    a, b = np.asarray(a, float).reshape(-1, 3), np.asarray(b, float).reshape(-1, 3)
    length = np.linalg.norm(b - a, axis=1)
    keep = length > 1e-9
    a, b, length = a[keep], b[keep], length[keep]
    e = len(a)
    t = (b - a) / length[:, None] if e else np.zeros((0, 3))
    n, bn = edge_frames(t)
    angle = np.arange(sides) * 2 * np.pi / sides
    ring = np.cos(angle)[None, :, None] * n[:, None, :] + np.sin(angle)[None, :, None] * bn[:, None, :]  # (E, S, 3)
    # rows from the a pole to the b pole: elevation -90 .. 0 (ring at a), 0 .. 90 (ring at b)
    centres, normals = [], []
    for r in range(cap_rows - 1, 0, -1):  # cap at a, from near the pole towards the ring
        theta = r / cap_rows * np.pi / 2
        normals.append(ring * np.cos(theta) - t[:, None, :] * np.sin(theta))
        centres.append(a)
    normals += [ring, ring]
    centres += [a, b]
    for r in range(1, cap_rows):
        theta = r / cap_rows * np.pi / 2
        normals.append(ring * np.cos(theta) + t[:, None, :] * np.sin(theta))
        centres.append(b)
    ring_normals = np.stack(normals, axis=1)  # (E, R, S, 3)
    ring_points = np.stack(centres, axis=1)[:, :, None, :] + radius * ring_normals
    num_rows = ring_normals.shape[1]
    per_edge = num_rows * sides + 2
    vertices = np.concatenate(
        [ring_points.reshape(e, -1, 3), (a - radius * t)[:, None], (b + radius * t)[:, None]], axis=1
    )
    vertex_normals = np.concatenate([ring_normals.reshape(e, -1, 3), -t[:, None], t[:, None]], axis=1)
    faces = []
    s0 = np.arange(sides)
    s1 = (s0 + 1) % sides
    for r in range(num_rows - 1):  # quads between consecutive rings (a side -> b side)
        lo, hi = r * sides, (r + 1) * sides
        faces += [np.column_stack([lo + s0, lo + s1, hi + s1]), np.column_stack([lo + s0, hi + s1, hi + s0])]
    pole_a, pole_b = num_rows * sides, num_rows * sides + 1
    last = (num_rows - 1) * sides
    faces += [np.column_stack([np.full(sides, pole_a), s1, s0])]
    faces += [np.column_stack([last + s0, last + s1, np.full(sides, pole_b)])]
    local = np.concatenate(faces)  # (F, 3) for one segment
    triangles = (local[None] + per_edge * np.arange(e)[:, None, None]).reshape(-1, 3)
    return vertices.reshape(-1, 3), vertex_normals.reshape(-1, 3), triangles


# }}}
