"""A skinned figure a Python user can run without Unity, and the volume sampler that fills it with points (vol.4
ch.1 section 1.4; docs/chapters/12-space-colonization.md, "What differs from the book").

The book grows branches inside a mixamo character ("Samba Dancing" on human_male_700) whose volume the VolumeSampler
package turned into a point cloud. Here:

* ``Figure``: 12 bones (0 hips = root, 1 spine, 2 chest, 3 head, 4/5 upper arm/forearm left, 6/7 right, 8/9 thigh/shin
  left, 10/11 right), 1.8 units tall, T-pose, facing -z. Its mesh is one closed capsule per bone (16 sides, 4 rings
  per half sphere), every vertex bound to its capsule's bone with weight 1 (the book's one-bone simplification).
  Bind poses are the inverse rest matrices; ``pose(t)`` is a looping dance (hips sway and bob, spine twist, arms
  swing in anti-phase, elbows and knees bend) through forward kinematics. Matrices are numpy row-major (B, 4, 4):
  world = M @ (x, y, z, 1).
* ``voxelize`` (after VolumeSampler): voxels of ``max extent / resolution``; a voxel is filled when its centre is
  inside, by signed ray crossings along +z per column (robust to the overlapping capsules).
* ``poisson_volume``: the VolumeSampler's dart throwing: one sample per voxel, candidates at random unit vectors
  times U(radius, 2 radius) around an active sample, accepted in a filled, unsampled voxel with no sample closer
  than radius; samples outside the surface are then dropped (a voxel is filled by its centre, so its corners may
  poke out), which the winding-number test ``inside_mesh`` decides.
* ``figure_cloud``: the three in a row, the figure's attraction cloud (cached: the book bakes it into an asset).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

# {{{ the figure

BONE_NAMES = (
    "hips",
    "spine",
    "chest",
    "head",
    "upper_arm_l",
    "forearm_l",
    "upper_arm_r",
    "forearm_r",
    "thigh_l",
    "shin_l",
    "thigh_r",
    "shin_r",
)
PARENTS = (-1, 0, 1, 2, 2, 4, 2, 6, 0, 8, 0, 10)
PIVOTS = np.array(
    [
        [0.0, 0.95, 0.0],
        [0.0, 1.10, 0.0],
        [0.0, 1.25, 0.0],
        [0.0, 1.52, 0.0],  # hips, spine, chest, head
        [0.20, 1.42, 0.0],
        [0.48, 1.42, 0.0],
        [-0.20, 1.42, 0.0],
        [-0.48, 1.42, 0.0],  # shoulders, elbows
        [0.10, 0.93, 0.0],
        [0.10, 0.50, 0.0],
        [-0.10, 0.93, 0.0],
        [-0.10, 0.50, 0.0],  # hips joints, knees
    ]
)
"""Rest position of each bone's joint (its pivot), units; the figure stands on y = 0, 1.8 tall."""
CAPSULES = (  # (start, end, radius) of each bone's capsule at rest
    ((0.0, 0.93, 0.0), (0.0, 1.10, 0.0), 0.14),
    ((0.0, 1.10, 0.0), (0.0, 1.25, 0.0), 0.14),
    ((0.0, 1.25, 0.0), (0.0, 1.38, 0.0), 0.14),
    ((0.0, 1.60, 0.0), (0.0, 1.69, 0.0), 0.11),
    ((0.20, 1.42, 0.0), (0.48, 1.42, 0.0), 0.05),
    ((0.48, 1.42, 0.0), (0.74, 1.42, 0.0), 0.04),
    ((-0.20, 1.42, 0.0), (-0.48, 1.42, 0.0), 0.05),
    ((-0.48, 1.42, 0.0), (-0.74, 1.42, 0.0), 0.04),
    ((0.10, 0.93, 0.0), (0.10, 0.50, 0.0), 0.075),
    ((0.10, 0.50, 0.0), (0.10, 0.07, 0.0), 0.055),
    ((-0.10, 0.93, 0.0), (-0.10, 0.50, 0.0), 0.075),
    ((-0.10, 0.50, 0.0), (-0.10, 0.07, 0.0), 0.055),
)
"""Torso 0.14, head 0.11, upper arm 0.05, forearm 0.04, thigh 0.075, shin 0.055
(docs/chapters/12-space-colonization.md, "What differs from the book")."""
CAPSULE_SIDES, CAPSULE_RINGS = 16, 4
"""Mesh resolution: sides around, rings per half sphere (plus one pole each)."""
HEIGHT = 1.8


def translation(v) -> np.ndarray:
    m = np.identity(4)
    m[:3, 3] = v
    return m


def rotation(axis: str, degrees: float) -> np.ndarray:
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    m = np.identity(4)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def capsule(start, end, radius: float, sides: int = CAPSULE_SIDES, rings: int = CAPSULE_RINGS):
    """A closed capsule mesh: (vertices (V, 3), triangles (T, 3)) wound counter-clockwise seen from outside."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    axis = end - start
    t = axis / np.linalg.norm(axis)
    helper = np.array([0.0, 0.0, 1.0]) if abs(t[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    n = np.cross(t, helper)
    n /= np.linalg.norm(n)
    bn = np.cross(t, n)
    angle = np.arange(sides) * 2 * np.pi / sides
    ring = np.cos(angle)[:, None] * n + np.sin(angle)[:, None] * bn
    rows = []
    for r in range(rings - 1, -1, -1):  # from the start pole's side to the start ring
        theta = r / rings * np.pi / 2
        rows.append(start + radius * (ring * np.cos(theta) - t * np.sin(theta)))
    for r in range(rings):  # from the end ring to the end pole's side
        theta = r / rings * np.pi / 2
        rows.append(end + radius * (ring * np.cos(theta) + t * np.sin(theta)))
    vertices = np.concatenate([*rows, [start - radius * t, end + radius * t]])
    s0 = np.arange(sides)
    s1 = (s0 + 1) % sides
    faces = []
    for r in range(len(rows) - 1):
        lo, hi = r * sides, (r + 1) * sides
        faces += [np.column_stack([lo + s0, lo + s1, hi + s1]), np.column_stack([lo + s0, hi + s1, hi + s0])]
    pole_a, pole_b, last = len(rows) * sides, len(rows) * sides + 1, (len(rows) - 1) * sides
    faces += [
        np.column_stack([np.full(sides, pole_a), s1, s0]),
        np.column_stack([last + s0, last + s1, np.full(sides, pole_b)]),
    ]
    return vertices, np.concatenate(faces)


@dataclass(frozen=True)
class Figure:
    """The procedural character: mesh, one bone per vertex, bind poses and the animation."""

    period: float = 2.4
    """Seconds per loop of the dance."""

    @property
    def bone_count(self) -> int:
        return len(PARENTS)

    def mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(vertices (V, 3), triangles (T, 3), bone of each vertex (V,)) at the rest pose; the capsule of bone b is
        ``triangles[b * T/B : (b + 1) * T/B]`` (see ``components``)."""
        vertices, triangles, bones = [], [], []
        base = 0
        for bone, (start, end, radius) in enumerate(CAPSULES):
            v, f = capsule(start, end, radius)
            vertices.append(v)
            triangles.append(f + base)
            bones.append(np.full(len(v), bone))
            base += len(v)
        return np.concatenate(vertices), np.concatenate(triangles), np.concatenate(bones)

    def components(self) -> list[np.ndarray]:
        """Triangle indices of each closed capsule (for ``inside_mesh``)."""
        per = len(self.mesh()[1]) // self.bone_count
        return [np.arange(b * per, (b + 1) * per) for b in range(self.bone_count)]

    def rest_world(self) -> np.ndarray:
        """Bone world matrices at the rest pose: translations to each pivot."""
        return np.stack([translation(p) for p in PIVOTS])

    def bind_poses(self) -> np.ndarray:
        """Unity's sharedMesh.bindposes: the inverse of each bone's rest world matrix."""
        return np.linalg.inv(self.rest_world())

    def local_rotations(self, time: float) -> tuple[list[np.ndarray], np.ndarray]:
        """Each bone's rotation at `time` and the hips' offset (a samba-like loop of `period` seconds)."""
        phase = 2 * math.pi * time / self.period
        s, s2 = math.sin(phase), math.sin(2 * phase)
        r = [np.identity(4) for _ in PARENTS]
        r[0] = rotation("z", 4.0 * s)  # hips roll with the sway
        r[1] = rotation("y", 20.0 * s)  # spine twist
        r[2] = rotation("x", 5.0 * s2)
        r[3] = rotation("y", -10.0 * s)
        r[4] = rotation("z", 35.0 * s)  # upper arms swing in anti-phase
        r[6] = rotation("z", 35.0 * s)
        r[5] = rotation("y", -(45.0 + 25.0 * s))  # elbows bend 20-70 degrees forward
        r[7] = rotation("y", 45.0 - 25.0 * s)
        r[8] = rotation("x", 20.0 * s)  # thighs alternate
        r[10] = rotation("x", -20.0 * s)
        r[9] = rotation("x", -22.5 * (1.0 - math.cos(phase)))  # knees 0-45 degrees
        r[11] = rotation("x", -22.5 * (1.0 + math.cos(phase)))
        hips = np.array([0.06 * s, 0.03 * s2, 0.0])  # sway and bob at double rate
        return r, hips

    def pose(self, time: float) -> np.ndarray:
        """Bone world matrices (B, 4, 4) at `time` (forward kinematics)."""
        rotations, hips = self.local_rotations(time)
        world = np.zeros((self.bone_count, 4, 4))
        for bone, parent in enumerate(PARENTS):  # parents come first
            if parent < 0:
                world[bone] = translation(PIVOTS[bone] + hips) @ rotations[bone]
            else:
                world[bone] = world[parent] @ translation(PIVOTS[bone] - PIVOTS[parent]) @ rotations[bone]
        return world

    def skinning(self, time: float) -> np.ndarray:
        """bone matrix @ bind pose per bone: what Animate applies (identity at the rest pose)."""
        return self.pose(time) @ self.bind_poses()


# }}}

# {{{ inside test, voxels, Poisson samples


def inside_mesh(
    points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray, components=None, chunk: int = 256
) -> np.ndarray:
    """Generalised winding number > 1/2 (van Oosterom and Strackee's solid angle per triangle): exact for closed,
    outward-wound meshes, and a union of overlapping closed pieces counts each piece once.

    ``components``: optional list of triangle index arrays, each a closed piece; a piece adds exactly 0 at points
    outside its bounding box, so only the pieces whose box holds a point are summed (the figure's 12 capsules)."""
    points = np.asarray(points, float).reshape(-1, 3)
    vertices, triangles = np.asarray(vertices, float), np.asarray(triangles)
    if components is None:
        components = [np.arange(len(triangles))]
    winding = np.zeros(len(points))
    for piece in components:
        tri = vertices[triangles[piece]]
        lower, upper = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
        near = np.flatnonzero(((points >= lower) & (points <= upper)).all(axis=1))
        for start in range(0, len(near), chunk):
            index = near[start : start + chunk]
            p = points[index, None, :]
            a, b, c = (tri[None, :, k, :] - p for k in range(3))
            la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
            numerator = np.einsum("ptk,ptk->pt", a, np.cross(b, c))
            denominator = (
                la * lb * lc
                + np.einsum("ptk,ptk->pt", a, b) * lc
                + np.einsum("ptk,ptk->pt", a, c) * lb
                + np.einsum("ptk,ptk->pt", b, c) * la
            )
            winding[index] += np.arctan2(numerator, denominator).sum(axis=1) / (2 * np.pi)
    return winding > 0.5


@dataclass(frozen=True)
class Volume:
    """Filled voxels of a mesh (the VolumeSampler's Volume asset, plus the voxel mask)."""

    filled: np.ndarray
    """(width, height, depth) bool, indexed [x, y, z]."""
    origin: np.ndarray
    """Corner of voxel (0, 0, 0)."""
    unit: float
    """Voxel edge length."""

    def centres(self, index: np.ndarray) -> np.ndarray:
        return self.origin + (np.asarray(index) + 0.5) * self.unit


def voxelize(vertices: np.ndarray, triangles: np.ndarray, resolution: int) -> Volume:
    """Voxels of max extent / resolution over the mesh bounds grown by half a voxel per side; a voxel is filled when
    the signed count of surface crossings below its centre along +z is positive (front faces +1, back faces -1)."""
    vertices = np.asarray(vertices, float)
    lower, upper = vertices.min(axis=0), vertices.max(axis=0)
    unit = float((upper - lower).max() / resolution)
    origin = lower - unit / 2
    dims = np.ceil((upper - lower + unit) / unit).astype(int)
    # ray positions: column centres nudged off any symmetry plane of the mesh (a ray through an edge counts twice)
    nudge = unit * np.array([1.234567e-4, 2.345678e-4])
    crossings: list[list[tuple[float, int]]] = [[] for _ in range(dims[0] * dims[1])]
    tri = vertices[np.asarray(triangles)]
    normal_z = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2]
    for k in np.flatnonzero(np.abs(normal_z) > 1e-15):
        t = tri[k]
        lo = np.floor((t[:, :2].min(axis=0) - origin[:2] - nudge) / unit - 0.5).astype(int)
        hi = np.ceil((t[:, :2].max(axis=0) - origin[:2] - nudge) / unit - 0.5).astype(int)
        lo, hi = np.maximum(lo, 0), np.minimum(hi, dims[:2] - 1)
        if (hi < lo).any():
            continue
        ix, iy = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1), indexing="ij")
        px = origin[0] + (ix.ravel() + 0.5) * unit + nudge[0]
        py = origin[1] + (iy.ravel() + 0.5) * unit + nudge[1]
        (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = t
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        w0 = ((x1 - px) * (y2 - py) - (x2 - px) * (y1 - py)) / area
        w1 = ((x2 - px) * (y0 - py) - (x0 - px) * (y2 - py)) / area
        w2 = 1.0 - w0 - w1
        hit = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        z = w0 * z0 + w1 * z1 + w2 * z2
        sign = 1 if normal_z[k] < 0 else -1  # a face looking towards -z is where the +z ray enters
        for column, depth in zip((ix.ravel() * dims[1] + iy.ravel())[hit], z[hit], strict=True):
            crossings[column].append((depth, sign))
    filled = np.zeros(dims, bool)
    z_centres = origin[2] + (np.arange(dims[2]) + 0.5) * unit
    for column, hits in enumerate(crossings):
        if not hits:
            continue
        hits.sort()
        depth = np.array([h[0] for h in hits])
        count = np.cumsum([h[1] for h in hits])
        below = np.searchsorted(depth, z_centres, side="right")  # crossings under each centre
        filled[column // dims[1], column % dims[1]] = np.where(below > 0, count[np.maximum(below - 1, 0)], 0) > 0
    return Volume(filled, origin, unit)


def poisson_volume(volume: Volume, rng: np.random.Generator, distance: float = 1.0, tries: int = 8) -> np.ndarray:
    """Dart throwing inside the filled voxels (VolumeSampler): samples at least `distance` voxels apart, at most one
    per voxel, returned in voxel (z, y, x) order as the Volume asset stores them."""
    filled, unit = volume.filled, volume.unit
    radius = distance * unit
    reach = max(1, math.ceil(distance))  # voxels to look at around a candidate
    nx, ny, nz = filled.shape
    ox, oy, oz = (float(v) for v in volume.origin)
    owner = np.full(filled.shape, -1)
    samples = np.zeros((int(filled.sum()), 3))  # one sample per filled voxel at most
    count = 0

    def voxel(x: float, y: float, z: float) -> tuple[int, int, int]:
        return math.floor((x - ox) / unit), math.floor((y - oy) / unit), math.floor((z - oz) / unit)

    def free(x: float, y: float, z: float) -> bool:
        i, j, k = voxel(x, y, z)
        if not (0 <= i < nx and 0 <= j < ny and 0 <= k < nz) or not filled[i, j, k] or owner[i, j, k] >= 0:
            return False
        near = owner[
            max(i - reach, 0) : i + reach + 1, max(j - reach, 0) : j + reach + 1, max(k - reach, 0) : k + reach + 1
        ]
        near = near[near >= 0]
        if not len(near):
            return True
        d = samples[near] - (x, y, z)
        return float(np.min(np.einsum("ij,ij->i", d, d))) >= radius * radius

    def add(x: float, y: float, z: float) -> int:
        nonlocal count
        owner[voxel(x, y, z)] = count
        samples[count] = (x, y, z)
        count += 1
        return count - 1

    while True:
        # (re)start in a filled voxel that no sample is near: every separate piece of the volume gets sampled
        taken = owner >= 0
        near = np.zeros_like(taken)
        dims = filled.shape
        for offset in np.ndindex(*(2 * reach + 1,) * 3):
            d = np.array(offset) - reach
            src = tuple(slice(max(0, -k), n - max(0, k)) for k, n in zip(d, dims, strict=True))
            dst = tuple(slice(max(0, k), n - max(0, -k)) for k, n in zip(d, dims, strict=True))
            near[dst] |= taken[src]
        starts = np.argwhere(filled & ~near)
        if not len(starts):
            break
        active = [add(*volume.centres(starts[rng.integers(len(starts))]))]
        while active:
            slot = int(rng.integers(len(active)))
            cx, cy, cz = samples[active[slot]]
            directions = rng.normal(size=(tries, 3))
            lengths = rng.uniform(radius, 2 * radius, tries) / np.maximum(np.linalg.norm(directions, axis=1), 1e-12)
            for (dx, dy, dz), length in zip(directions.tolist(), lengths.tolist(), strict=True):
                x, y, z = cx + dx * length, cy + dy * length, cz + dz * length
                if free(x, y, z):
                    active.append(add(x, y, z))
                    break
            else:
                active[slot] = active[-1]  # this sample has no room left around it
                active.pop()
    points = samples[:count]
    v = np.floor((points - volume.origin) / unit).astype(int)
    return points[np.lexsort((v[:, 0], v[:, 1], v[:, 2]))]


@functools.lru_cache(maxsize=4)
def figure_cloud(resolution: int, sample_distance: float, tries: int, seed: int) -> tuple[np.ndarray, float]:
    """Attraction points filling the procedural figure at rest (VolumeSampler: voxels, then Poisson samples, those
    outside the surface dropped), and the voxel unit. Cached: the book bakes this into an asset once."""
    figure = Figure()
    vertices, triangles, _ = figure.mesh()
    volume = voxelize(vertices, triangles, resolution)
    points = poisson_volume(volume, np.random.default_rng(seed), sample_distance, tries)
    inside = inside_mesh(points, vertices, triangles, figure.components())
    return points[inside], volume.unit


# }}}
