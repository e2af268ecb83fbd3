"""``ugpcl bench multiplane_projection``: RenderFaces' frame time and ray-marched pixels per second, with the march's
flop count (its steps replayed in numpy) (vol.1 ch.9)."""

from __future__ import annotations

import math

import numpy as np

from ..geometry.multiplane_projection import SHAPE_BOX, SHAPE_SPHERE
from ..scenes.multiplane_projection import MARCH_STEPS, MAX_DISTANCE, SURFACE_EPSILON, Params, Simulation
from .timing import seconds_per_call

MARCH_STEP_FLOPS = 7
"""One sphere-tracing step of trace() besides its shapes: p = origin + t dir (6) and t += nearest (1). Flop
convention of the benches: an FMA is 2, sqrt and a division 1 each, compares, min and max 0."""

SHAPE_DISTANCE_FLOPS = {SHAPE_SPHERE: 10, SHAPE_BOX: 13}
"""shape_distance() per shape and step: q = p - centre (3), length (dot 5, sqrt 1), then a sphere's - radius (1);
a box's |q| - half extents (3), length of the positive part (6) and the sum (1). The per-pixel direction, hit
shading and fog (about 60) are left out: the march's shapes x steps dominate."""


def march_steps(sim, samples: int = 16384) -> float:
    """Mean sphere-tracing steps per face pixel of RenderFaces: trace()'s march loop replayed in numpy (float64) on
    every stride-th pixel of each face, about ``samples`` of them (at least every 4th; the kernel keeps no count, and
    rounding may end a ray one step apart)."""
    p = sim.params
    width, height = p.face_resolution
    stride = max(4, math.ceil(math.sqrt(width * height / samples)))
    lens, basis, origin = sim.cameras.lens().astype(np.float64), sim.cameras.basis, np.asarray(sim.eye_cg, float)
    centres, sizes = sim.shapes["center"].astype(np.float64), sim.shapes["size"].astype(np.float64)
    sphere = centres[:, 3] == SHAPE_SPHERE
    i, j = np.meshgrid(np.arange(0, width, stride), np.arange(0, height, stride), indexing="xy")
    x, y = 2.0 * (i.ravel() + 0.5) / width - 1.0, 2.0 * (j.ravel() + 0.5) / height - 1.0
    counts = []
    for k in range(p.faces):
        right, up, forward = np.asarray(basis[k], np.float64).reshape(3, 3)
        vx, vy = (x + lens[k, 1]) / lens[k, 0], (y + lens[k, 3]) / lens[k, 2]
        d = vx[:, None] * right + vy[:, None] * up + forward
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        down = (d[:, 1] < 0.0) & (origin[1] > p.ground_y)
        t_ground = np.where(down, (p.ground_y - origin[1]) / np.where(down, d[:, 1], -1.0), np.inf)
        t_limit, t = np.minimum(t_ground, MAX_DISTANCE), np.zeros(len(d))
        steps, going = np.zeros(len(d), int), np.ones(len(d), bool)
        for _ in range(MARCH_STEPS):
            going &= t < t_limit
            if not going.any():
                break
            q = origin + t[going, None] * d[going]
            rel = q[:, None, :] - centres[None, :, :3]
            box = np.linalg.norm(np.maximum(np.abs(rel) - sizes[None, :, :3], 0.0), axis=2) + np.minimum(
                (np.abs(rel) - sizes[None, :, :3]).max(axis=2), 0.0
            )
            nearest = np.where(sphere, np.linalg.norm(rel, axis=2) - sizes[None, :, 0], box).min(axis=1, initial=np.inf)
            steps[going] += 1
            hit = nearest < SURFACE_EPSILON
            t[going] += np.where(hit, 0.0, nearest)
            going[np.nonzero(going)[0][hit]] = False
        counts.append(steps)
    return float(np.concatenate(counts).mean())


def bench(runtime, sizes=None) -> list[dict]:
    """ms per frame of RenderFaces (the 5 face images of the book's room) at face resolutions W x W/2, and the
    ray-marched pixels per second; march flop/s = (MARCH_STEP_FLOPS + SHAPE_DISTANCE_FLOPS of every shape) per
    march step x march_steps per pixel x pixels per second."""
    sizes = sizes or ([1024, 2048, 4096] if runtime.is_gpu else [128, 256])
    rows = []
    for width in sizes:
        height = max(1, width // 2)
        sim = Simulation(runtime, Params(face_resolution=(width, height), view_resolution=(16, 16)), seed=0)
        seconds = seconds_per_call(sim.render_faces, runtime.queue, max_calls=50)
        pixels = sim.params.faces * width * height
        step_flops = MARCH_STEP_FLOPS + sum(SHAPE_DISTANCE_FLOPS[float(w)] for w in sim.shapes["center"][:, 3])
        flops = step_flops * march_steps(sim) * pixels
        rows.append(
            {
                "face": f"{width}x{height}",
                "ms/frame": seconds * 1e3,
                "Mpixel/s": pixels / seconds / 1e6,
                "march flop/s": flops / seconds,
            }
        )
    return rows
