"""``ugpcl bench projection_spray``: painted texels per second for one or eight spheres per texture size, with and
without tile skipping, with the least memory traffic of a frame (SPRAY_TEXEL_BYTES, PAINT_TEXEL_BYTES) for the
share column."""

from __future__ import annotations

import numpy as np

from ..geometry.projection_spray import Drawable, island_gutter, placed
from ..geometry.uv_atlas import uv_sphere
from ..scenes.projection_spray import TILE, Params, Simulation
from .timing import seconds_per_step

SPRAY_TEXEL_BYTES = 80
"""Least memory traffic per texel of a sprayed tile, float4 texels: SprayDraw reads pos_tex and nrm_tex (32; the
spray's depth map and shape come from cache) and EdgeThicken reads pos_tex and the paint and writes the canvas (48).
The ring of tiles EdgeThicken adds around the sprayed ones and the depth map's pass are not counted."""

PAINT_TEXEL_BYTES = 32
"""What a texel the paint changes adds: SprayDraw reads and writes its paint texel (16 each)."""


def bench(runtime, sizes=None) -> list[dict]:
    """Painted texels/s: one frame (depth map, SprayDraw, EdgeThicken) per step, spraying 1 or 8 unit spheres
    (bench_spheres) from 12 units, per texture size, with and without tile skipping. texels/s counts every texel
    the sample's passes touch (objects x tex^2 per frame); painted texels/s only those the paint changed.
    frame bytes/s: SPRAY_TEXEL_BYTES per texel of the tiles sprayed and PAINT_TEXEL_BYTES per painted texel, per
    second."""
    sizes = sizes or ([1024, 2048] if runtime.is_gpu else [128, 256])
    rows = []
    for tex in sizes:
        for objects in (1, 8):
            for skip in (False, True):
                params = Params(
                    tex=tex, depth_res=min(tex, 1024), hue_cycle=False, rotation_speed=0.0, aim="fixed", skip_tiles=skip
                )
                sim = Simulation(runtime, params, seed=0)
                sim.set_drawables(bench_spheres(tex, objects, params.edge_texels))
                before = np.stack([t["paint"].get() for t in sim.textures])
                sim.step()
                painted = int(np.any(np.stack([t["paint"].get() for t in sim.textures]) != before, axis=-1).sum())
                seconds = seconds_per_step(sim, max_steps=20)
                rows.append(
                    {
                        "tex": tex,
                        "objects": objects,
                        "skip tiles": skip,
                        "ms/frame": seconds * 1e3,
                        "texels/s": objects * tex * tex / seconds,
                        "painted texels/s": painted / seconds,
                        "tiles sprayed": sim.tiles_last,
                        "frame bytes/s": (
                            SPRAY_TEXEL_BYTES * sim.tiles_last * TILE * TILE + PAINT_TEXEL_BYTES * painted
                        )
                        / seconds,
                    }
                )
    return rows


def bench_spheres(tex: int, count: int, edge_texels: int) -> list[Drawable]:
    """``count`` (<= 9) unit spheres 4 units apart on a 3-wide grid around the cube_sphere spray's aim centre: the outer
    ones lie only partly in its cone."""
    sphere = uv_sphere(tex, island_gutter(tex, edge_texels))
    grid = sorted(((x * 4.0, y * 4.0, 0.0) for y in (-1, 0, 1) for x in (-1, 0, 1)), key=np.linalg.norm)
    spots = grid[:count]  # the centre first: one sphere is the one the spray points at
    return [Drawable(f"sphere{i}", sphere, placed(1.0, spot), rotates=False) for i, spot in enumerate(spots)]
