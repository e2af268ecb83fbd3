"""Triangulation by ear clipping: polygons with holes and nested islands cut into triangles (vol.4 ch.5;
docs/chapters/16-ear-clipping.md).

The book's algorithm runs on the host (``ugpcl.geometry.ear_clipping``): containment tree, holes bridged into their
outer ring, FIFO ear list. A reset triangulates the scene's rings (a preset, ``input=rings.json`` or the rings drawn
in the view; ``ugpcl.geometry.ear_clipping_input``); each step then reveals ``clips_per_step`` more clipped ears, so
the view replays the ear list. The .npz and ``--mesh`` always hold the whole result. One kernel, ``EarClipping``
(clkernels/ear_clipping.cl), clips many small polygons at once, one work-item each (``ear_clip_batch``;
``ugpcl bench ear_clipping``).

Differences from the book: rings are sorted exactly by area and by right-most x (``variant=book`` uses the book's
truncating comparator); a hole that no bridge reaches is reported (the book drops it silently); ``delaunay=true``
flips the result into the constrained Delaunay triangulation; the glyph preset outlines text with matplotlib's
bundled DejaVu Sans (the chapter names font outlines as the use).
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib.util import find_spec

import numpy as np

from ..geometry import ear_clipping as ec
from ..geometry.ear_clipping_input import PRESETS, clean_ring, glyph_rings, load_rings
from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..inputs import InputError
from ..scene import Animation, ParamError, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

MAX_BATCH_VERTICES = 64
"""Largest polygon of the batch kernel (its MAX_VERTICES: private index ring and ear list)."""
BOOKKEEPING = ("touching points inserted", "rings split where they touch themselves")
"""What the robust pre-pass does that leaves the input's points and area as they are (not reported as altered)."""
RECORD_LIMIT = 4096
"""Scenes with more vertices than this keep no ear-list trace (it grows as vertices x clips)."""
MAX_TEXT = 64
"""Longest text of the glyph preset."""


@dataclass(frozen=True)
class Params(BaseParams):
    preset: str = param("nested", choices=tuple(PRESETS), used_only_when={"input": ""})
    """The rings to triangulate (nested: the book's TriangulationTest scene; draw: start empty, as DrawTest)."""
    input: str = ""
    """Path of a JSON file {"rings": [[[x, y], ...], ...]}; when set it replaces the preset. At most 16 MiB and
    200000 points in all, |x|, |y| <= 1e9; each ring 3 or more distinct points with an area; rings may touch, edges
    may not cross (but two edges one apart: a local self-intersection, cured)."""
    text: str = param("ugpcl", used_only_when={"preset": "glyph", "input": ""})
    """Text of the glyph preset (1 to 64 characters)."""
    text_size: float = param(4.0, 0.0, 1000.0, lo_open=True, used_only_when={"preset": "glyph", "input": ""})
    """Em size of the glyph preset, world units."""
    variant: str = param("robust", choices=("robust", "fixed", "book"))
    """robust: any rings real outlines hold (touching, pinched, repeated and collinear points, aligned holes, local
    self-intersections), exact signs, never area left uncovered; fixed: the book's pipeline with exact, stable sorts;
    book: the chapter as written (its FloorToInt comparator)."""
    strict: bool = False
    """A result that leaves input area uncovered or had to alter the input is an error (exit 1), not a warning."""
    delaunay: bool = False
    """Flip the ear-clipped triangles into the constrained Delaunay triangulation (Lawson flips; not in the book)."""
    compare_earcut: bool = False
    """Also triangulate with mapbox-earcut (earcut_triangles, earcut_area in the .npz)."""
    clips_per_step: int = param(1, 1, 1 << 20, live=True)
    """Clipped ears the replay reveals per step (the view's animation speed)."""

    def check(self) -> None:
        if not 1 <= len(self.text) <= MAX_TEXT:
            raise ValueError(f"text must have 1 to {MAX_TEXT} characters, got {len(self.text)}")
        if self.input:
            load_rings(self.input)  # read and checked with the parameters (cached for the reset): one line
        elif self.preset == "glyph" and find_spec("matplotlib") is None:
            raise ValueError("preset=glyph needs matplotlib (the render extra): pip install 'ugpcl[render]'")
        elif self.preset == "glyph" and not glyph_rings(self.text, self.text_size):
            raise ValueError(f"text {self.text!r} has no glyph outlines to triangulate (preset=glyph)")


class Simulation(BaseSimulation):
    """A reset triangulates the rings; each step reveals the next ``clips_per_step`` clipped ears."""

    Params = Params

    def _reset(self) -> None:
        p = self.params
        if p.input:
            try:
                self.rings = list(load_rings(p.input))
            except InputError as err:  # edited since check() read it
                raise ParamError(str(err)) from None
        elif p.preset == "glyph":
            self.rings = glyph_rings(p.text, p.text_size)
        else:
            self.rings = [clean_ring(r) for r in PRESETS[p.preset]()]
        self.triangulate()

    # {{{ the chapter's Triangulate, and the rings drawn in the view (DrawTest)

    def triangulate(self) -> None:
        """Triangulate every ring; the replay starts again at the first clip."""
        p = self.params
        record = sum(len(r) for r in self.rings) <= RECORD_LIMIT
        self.result = ec.triangulate(self.rings, p.variant, record=record)
        self.ear_triangles = self.result.triangles
        self.triangles = ec.delaunay_flip(self.result) if p.delaunay else self.ear_triangles
        self.clips = 0

    def add_ring(self, points) -> None:
        """A drawn ring (DrawTest's right click): at least 3 distinct vertices."""
        ring = clean_ring(points)
        if len(ring) < 3:
            raise ValueError(f"a ring needs at least 3 distinct vertices, got {len(ring)}")
        self.rings.append(ring)
        self.triangulate()

    def undo_ring(self) -> None:
        """DrawTest's U: drop the last ring (nothing when there is none; the original throws)."""
        if self.rings:
            self.rings.pop()
            self.triangulate()

    def clear_rings(self) -> None:
        """DrawTest's C: no rings at all."""
        self.rings = []
        self.triangulate()

    # }}}

    def _step(self, dt: float) -> None:
        self.clips = min(len(self.ear_triangles), self.clips + self.params.clips_per_step)

    def seek(self, clip: int) -> None:
        """Show the first ``clip`` clipped ears (clamped to 0 .. all)."""
        self.clips = int(np.clip(clip, 0, len(self.ear_triangles)))

    @property
    def done(self) -> bool:
        return self.clips >= len(self.ear_triangles)

    def ear_list(self, clip: int | None = None) -> tuple[int, ...]:
        """The ear list (global vertex indices, head first) when ear number ``clip`` (default: the next) is clipped;
        empty when done or when the scene was too large to record."""
        clip = self.clips if clip is None else clip
        trace = self.result.ear_trace
        return trace[clip] if trace is not None and clip < len(trace) else ()

    def input_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The rings flattened: input_vertices (N, 2), input_ring_offsets (R + 1,)."""
        offsets = np.cumsum([0] + [len(r) for r in self.rings]).astype(np.int32)
        vertices = np.concatenate(self.rings) if self.rings else np.zeros((0, 2))
        return vertices, offsets

    def earcut(self) -> np.ndarray:
        """mapbox-earcut on every top-level group (outer ring + its holes), as indices into input_vertices."""
        import mapbox_earcut

        _, offsets = self.input_arrays()
        found = []
        for group in self.result.group_rings:
            group = list(dict.fromkeys(group))  # a ring split where it touches itself is in its groups once
            rings = [self.rings[i] for i in group]
            ends = np.cumsum([len(r) for r in rings]).astype(np.uint32)
            local = mapbox_earcut.triangulate_float64(np.concatenate(rings), ends).astype(np.int64)
            starts = np.concatenate([[0], ends[:-1]]).astype(np.int64)
            ring_of = np.searchsorted(ends, local, side="right")  # which ring of the group each index falls in
            found.append(local - starts[ring_of] + offsets[np.asarray(group)[ring_of]])
        return np.concatenate(found).reshape(-1, 3).astype(np.int32) if found else np.zeros((0, 3), np.int32)

    def state(self) -> dict[str, np.ndarray]:
        r = self.result
        vertices, offsets = self.input_arrays()
        state = {
            "vertices": r.vertices,
            "triangles": self.triangles,
            "uv": r.uv,
            "group_offsets": r.group_offsets,
            "complete": r.complete,
            "input_vertices": vertices,
            "input_ring_offsets": offsets,
            "tree_parent": r.tree_parent,
            "tree_level": r.tree_level,
            "area_input": np.float64(self.area_input),
            "area_output": np.float64(self.area_output),
            "deviation": np.float64(self.deviation),
            "clips": np.int32(self.clips),
        }
        if self.params.delaunay:
            state["ear_triangles"] = self.ear_triangles
        if r.ear_trace is not None:
            state["ear_trace"] = np.asarray([v for ears in r.ear_trace for v in ears], np.int32)
            state["ear_trace_offsets"] = np.cumsum([0] + [len(e) for e in r.ear_trace]).astype(np.int32)
        if self.params.compare_earcut:
            found = self.earcut()
            state["earcut_triangles"] = found
            state["earcut_area"] = np.float64(np.abs(ec.triangle_signed_areas(vertices, found)).sum())
        return state

    def stats(self) -> dict:
        r = self.result
        return {
            **super().stats(),
            "rings": len(self.rings),
            "groups": len(r.complete),
            "vertices": len(r.vertices),
            "triangles": len(self.triangles),
            "complete": bool(r.complete.all()),
            "deviation": self.deviation,
            "dropped holes": len(r.dropped),
            **({"input altered": ", ".join(f"{v} {k}" for k, v in r.altered.items())} if r.altered else {}),
            "clips shown": self.clips,
        }

    @property
    def area_input(self) -> float:
        """|outer| - |holes| + |islands| ..., nested as the input rings alone say (not as the clipper's tree)."""
        return ec.input_area(self.rings, [level + 1 for level in ec.nesting_levels(self.rings)])

    @property
    def area_output(self) -> float:
        return float(np.abs(ec.triangle_signed_areas(self.result.vertices, self.triangles)).sum())

    @property
    def deviation(self) -> float:
        """(input area - triangles' area) / input area: the share of the input left uncovered (< 0: covered twice)."""
        wanted = self.area_input
        return (wanted - self.area_output) / wanted if wanted else 0.0

    def incomplete(self) -> str:
        """One line when the triangles fall short of the input or the input had to be altered: what happened and the
        area deviation."""
        r = self.result
        failed, dropped = int((~r.complete).sum()), len(r.dropped)
        cured = {k: v for k, v in r.altered.items() if k not in BOOKKEEPING}
        if not failed and not dropped and not cured and abs(self.deviation) <= 1e-9:
            return ""
        why = [f"{count} {what}" for what, count in cured.items()]
        if failed:
            why.append(f"{failed} of {len(r.complete)} polygons ran out of ears")
        if dropped:
            why.append(f"{dropped} holes were dropped")
        head = "input altered" if cured and not failed and not dropped else "triangulation incomplete"
        return (
            f"{head}: {', '.join(why) or 'the triangles do not match the input'}; the triangles "
            f"cover {self.area_output:.6g} of the input's {self.area_input:.6g} ({100 * self.deviation:.3g} % "
            "uncovered)"
        )

    def mesh(self) -> Mesh:
        """The triangles as a flat mesh at z = 0, facing +z: the book's clockwise triangles (Unity, left-handed,
        seen from -z) become counter-clockwise ones seen from +z in right-handed glTF/OBJ coordinates."""
        r = self.result
        vertices = np.column_stack([r.vertices, np.zeros(len(r.vertices))])
        normals = np.tile(np.array([0.0, 0.0, 1.0]), (len(r.vertices), 1))
        return Mesh(vertices, self.triangles[:, ::-1], normals, r.uv)

    def export_mesh(self, path) -> None:
        """--mesh: the flat mesh (bridge copies kept as separate vertices, as the book's mesh)."""
        write_mesh(path, self.mesh())


# {{{ the batch kernel (not in the book)


def ear_clip_batch(runtime, polygons, robust: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clip many merged clockwise polygons (holes already bridged: ``ec.merged_polygons``) at once, one work-item
    each (EarClipping; ``robust``: built with ROBUST=1, the robust default's clipper, else the book's).

    Returns (triangles (sum(n_i - 2), 3) int32 indices into the concatenated vertices, counts (P,) int32 of rows
    written per polygon, finished (P,) bool: covered whole); polygon i's rows start at offsets[i] - 2 i and
    unwritten rows are -1."""
    polygons = [np.asarray(p, np.float64).reshape(-1, 2) for p in polygons]
    sizes = np.array([len(p) for p in polygons], np.int64)
    if len(polygons) == 0:
        return np.zeros((0, 3), np.int32), np.zeros(0, np.int32), np.zeros(0, bool)
    if sizes.min() < 3 or sizes.max() > MAX_BATCH_VERTICES:
        raise ValueError(f"polygons must have 3 to {MAX_BATCH_VERTICES} vertices, got {sizes.min()}..{sizes.max()}")
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int32)
    return clip_batch(runtime, np.concatenate(polygons), offsets, robust)


def clip_batch(runtime, points: np.ndarray, offsets: np.ndarray, robust: bool = True):
    """EarClipping on polygons already checked and concatenated (``offsets``: (P + 1,) int32 into ``points``):
    uploads, one launch, the triangles, counts and finished flags read back (what the bench times)."""
    count = len(offsets) - 1
    program = runtime.program("ear_clipping", MAX_VERTICES=MAX_BATCH_VERTICES, ROBUST=int(robust))
    points_d = runtime.to_device(np.ascontiguousarray(points, np.float64))
    offsets_d = runtime.to_device(offsets)
    triangles_d = runtime.to_device(np.full((int(offsets[-1]) - 2 * count) * 3, -1, np.int32))
    counts_d = runtime.zeros(count, np.int32)
    finished_d = runtime.zeros(count, np.uint8)
    kernel = program.kernel("EarClipping")
    kernel.over(count, 64, points_d, offsets_d, triangles_d, counts_d, finished_d, np.int32(count))
    return triangles_d.get().reshape(-1, 3), counts_d.get(), finished_d.get().astype(bool)


def ear_clip_large(runtime, polygon: np.ndarray) -> tuple[np.ndarray, bool]:
    """One merged clockwise polygon of any size by EarClippingLarge (one work-item: a CPU device's compiled C; on a
    GPU one thread is slow, the host is the better choice there): (triangles (T, 3) int32 local indices, whether it
    is covered). The grid has about 4 cells per vertex."""
    pts = np.ascontiguousarray(polygon, np.float64).reshape(-1, 2)
    n = len(pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    grid = int(min(2048, max(1, np.ceil(2.0 * np.sqrt(n)))))
    extent = float(max(hi - lo)) or 1.0
    program = runtime.program("ear_clipping", MAX_VERTICES=MAX_BATCH_VERTICES, ROBUST=1)
    pts_d = runtime.to_device(pts)
    ints = [runtime.zeros(size, np.int32) for size in (n, n, n + 1, n + 1)]
    flags = [runtime.zeros(n, np.uint8) for _ in range(2)]
    cell_head = runtime.to_device(np.full(grid * grid, -1, np.int32))
    cell_next = runtime.zeros(n, np.int32)
    triangles = runtime.to_device(np.full(max(n - 2, 1) * 3, -1, np.int32))
    result = runtime.zeros(2, np.int32)
    kernel = program.kernel("EarClippingLarge")
    kernel(
        (1,), (1,), pts_d, np.int32(n), *ints, *flags, cell_head, cell_next, _double2(lo),
        np.float64(grid / extent), np.int32(grid), triangles, result,
    )  # fmt: skip
    emitted, done = result.get().tolist()
    return triangles.get().reshape(-1, 3)[:emitted], bool(done)


def _double2(v) -> np.ndarray:
    import pyopencl.cltypes as cltypes

    return cltypes.make_double2(float(v[0]), float(v[1]))


def triangulate_batch(runtime, outlines) -> tuple[list[np.ndarray], int]:
    """Real outlines (each a list of rings) triangulated in one launch: the robust pre-pass on the host
    (``ec.merged_polygons``), the robust EarClipping kernel on every merged polygon of up to MAX_BATCH_VERTICES
    vertices, EarClippingLarge on larger ones on a CPU device, the host's robust clipper (``ec.clip_robust``, with
    its last-resort stage) on larger ones on a GPU and on any the kernels could not finish. Returns (per outline
    its triangles, (T, 3, 2) float64 corners, clockwise, y up; how many merged polygons a kernel tried and left to
    the host)."""
    merged = [ec.merged_polygons(rings) for rings in outlines]
    flat = [(k, poly) for k, polys in enumerate(merged) for poly in polys]
    small = [i for i, (_, poly) in enumerate(flat) if len(poly) <= MAX_BATCH_VERTICES]
    found: list[list[np.ndarray]] = [[] for _ in outlines]
    if small:
        polys = [flat[i][1] for i in small]
        sizes = np.array([len(p) for p in polys])
        offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int32)
        points = np.concatenate(polys)
        triangles, counts, finished = clip_batch(runtime, points, offsets)
        for j, i in enumerate(small):
            if finished[j]:
                start = offsets[j] - 2 * j
                found[flat[i][0]].append(points[triangles[start : start + counts[j]]])
    done = {small[j] for j in range(len(small)) if finished[j]} if small else set()
    left = len(small) - len(done)
    for i, (k, poly) in enumerate(flat):
        if i in done:
            continue
        covered = False
        if len(poly) > MAX_BATCH_VERTICES and not runtime.is_gpu:
            local, covered = ear_clip_large(runtime, poly)
            left += not covered
        if not covered:
            local, _ = ec.clip_robust(poly)
        found[k].append(poly[np.asarray(local, np.int64).reshape(-1, 3)])
    return [np.concatenate(f) if f else np.zeros((0, 3, 2)) for f in found], left


# }}}


SCENES = [
    Scene(
        "ear_clipping",
        Simulation,
        "Polygons with holes and nested islands triangulated by ear clipping (vol.4 ch.5)",
        preview={"steps": 1, "preset": "glyph", "clips_per_step": 1 << 20},
        animation=Animation(
            "the ear list replays, 4 clipped ears a frame, until the glyph is triangulated",
            start=0,
            overrides={"clips_per_step": 4},
        ),
    ),
]
