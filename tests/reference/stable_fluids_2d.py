"""The numpy float64 reference of the 2D stable fluids: every kernel of clkernels/stable_fluids_2d.cl and a whole
step in the book's order, written from the book's Solver2D.compute (vol.1 §4.6-4.8) as the "Kernels" section of
docs/chapters/04-stable-fluids-2d.md restates it. test_stable_fluids_2d and test_tessellation (whose fluid is this
one) compare the kernels against it.

Fields are indexed [y, x]; every neighbour read is zero outside the grid (D3D's out-of-range texture read)."""

from __future__ import annotations

import numpy as np

DT = 1.0 / 60.0
"""The step of step_ref unless given: the scenes' 60 frames per second."""


def shifted(f: np.ndarray, dx: int, dy: int) -> np.ndarray:
    """g[y, x] = f[y + dy, x + dx], 0 outside the grid."""
    h, w = f.shape[:2]
    pad = [(1, 1), (1, 1)] + [(0, 0)] * (f.ndim - 2)
    p = np.pad(f, pad)
    return p[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w]


def brush_ref(w, h, center, move, radius):
    x, y = np.meshgrid(np.arange(w), np.arange(h))
    q = np.stack([((x + 0.5) / w - center[0]) / radius, ((y + 0.5) / h - center[1]) / radius], axis=-1)
    f = np.clip(1.0 - (q**2).sum(-1), 0.0, 1.0)
    return np.stack([move[0] * f, move[1] * f, f, 0 * f], axis=-1)


def edges(w, h):
    """(x, y, inner x, inner y, normal axis) of every edge cell, corners excluded."""
    out = [(0, y, 1, y, 0) for y in range(1, h - 1)] + [(w - 1, y, w - 2, y, 0) for y in range(1, h - 1)]
    return out + [(x, 0, x, 1, 1) for x in range(1, w - 1)] + [(x, h - 1, x, h - 2, 1) for x in range(1, w - 1)]


def corners(w, h, typo=False):
    """(x, y, (ax, ay), (bx, by)): each corner and its two edge neighbours; typo = the book's divergence corner."""
    return [
        (0, 0, (1, 0), (0, 1)),
        (0, h - 1, (1, h - 2) if typo else (1, h - 1), (0, h - 2)),
        (w - 1, 0, (w - 2, 0), (w - 1, 1)),
        (w - 1, h - 1, (w - 2, h - 1), (w - 1, h - 2)),
    ]


def boundary_copy(f, channel=None, typo=False):
    """SetBoundaryDensity (channel None), SetBoundaryDivergence (prev, 1), SetBoundaryDivPositive (prev, 0)."""
    g = f.copy()
    h, w = f.shape[:2]
    sel = (lambda y, x: (y, x)) if channel is None else (lambda y, x: (y, x, channel))
    for x, y, ix, iy, _ in edges(w, h):
        g[sel(y, x)] = f[sel(iy, ix)]
    for x, y, (ax, ay), (bx, by) in corners(w, h, typo):
        g[sel(y, x)] = 0.5 * (g[sel(ay, ax)] + g[sel(by, bx)])
    return g


def boundary_velocity(v):
    g = v.copy()
    h, w = v.shape[:2]
    for x, y, ix, iy, axis in edges(w, h):
        g[y, x, axis] = -v[iy, ix, axis]  # the normal component negated, the tangential one kept
    for x, y, (ax, ay), (bx, by) in corners(w, h):
        g[y, x] = 0.5 * (g[ay, ax] + g[by, bx])
    return g


def neighbour_sum(f):
    return shifted(f, -1, 0) + shifted(f, 1, 0) + shifted(f, 0, -1) + shifted(f, 0, 1)


def diffuse_ref(field, prev_part, a):
    return (prev_part + a * neighbour_sum(field)) / (1 + 4 * a)


def project_step1_ref(vel, prev, book):
    h, w = vel.shape[:2]
    du = shifted(vel[..., 0], 1, 0) - shifted(vel[..., 0], -1, 0)
    dv = shifted(vel[..., 1], 0, 1) - shifted(vel[..., 1], 0, -1)
    div = (-0.5 * du / w + dv / h) if book else -0.5 * (du / w + dv / h)
    out = np.zeros_like(prev)
    out[..., 1], out[..., 2] = div, prev[..., 2]
    return out


def project_step2_ref(prev):
    out = prev.copy()
    out[..., 0] = (prev[..., 1] + neighbour_sum(prev[..., 0])) / 4
    return out


def project_step3_ref(vel, prev):
    h, w = vel.shape[:2]
    p = prev[..., 0]
    out = vel.copy()
    out[..., 0] -= 0.5 * (shifted(p, 1, 0) - shifted(p, -1, 0)) * w
    out[..., 1] -= 0.5 * (shifted(p, 0, 1) - shifted(p, 0, -1)) * h
    return out


def bilinear_ref(field, bx, by):
    """field (H, W, C) sampled at back-traced points with zero outside (the book's four taps)."""
    h, w = field.shape[:2]
    x0, y0 = np.floor(bx).astype(int), np.floor(by).astype(int)
    s1, t1 = (bx - x0)[..., None], (by - y0)[..., None]

    def tap(x, y):
        inside = ((x >= 0) & (x < w) & (y >= 0) & (y < h))[..., None]
        return np.where(inside, field[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)], 0.0)

    return (1 - s1) * ((1 - t1) * tap(x0, y0) + t1 * tap(x0, y0 + 1)) + s1 * (
        (1 - t1) * tap(x0 + 1, y0) + t1 * tap(x0 + 1, y0 + 1)
    )


def back_trace_ref(vel, dfdt, book):
    h, w = vel.shape[:2]
    y, x = np.mgrid[0:h, 0:w].astype(float)
    bx, by = x - dfdt * vel[..., 0], y - dfdt * vel[..., 1]
    if not book:
        bx, by = np.clip(bx, 0.5, w - 1.5), np.clip(by, 0.5, h - 1.5)
    return bx, by


def advect_velocity_ref(prev, dfdt, book):
    return bilinear_ref(prev[..., :2], *back_trace_ref(prev[..., :2], dfdt, book))


def advect_density_ref(vel, prev, dfdt, book):
    return bilinear_ref(prev[..., 2:3], *back_trace_ref(vel, dfdt, book))[..., 0]


def project_ref(vel, prev, book, sweeps):
    prev = project_step1_ref(vel, prev, book)
    prev = boundary_copy(boundary_copy(prev, 1, typo=book), 0)
    for _ in range(sweeps):
        prev = boundary_copy(project_step2_ref(prev), 0)
    return boundary_velocity(project_step3_ref(vel, prev)), prev


def step_ref(s, p, brush, dt=DT):
    """One Update() in the book's order (vol.1 §4.8 "Each item step of the simulation")."""
    vel, dens, prev, source = (s[k].astype(np.float64) for k in ("velocity", "density", "prev", "source"))
    h, w = dens.shape
    book = p.variant == "book"
    sweeps = p.gs_iterations if p.solver == "vol1" else 0
    dfdt = dt * (w + h) * 0.5
    if brush is not None:
        source = brush_ref(w, h, brush[:2], brush[2:], p.source_radius)
    if not p.density_only:
        if brush is not None:
            add = source[..., :2] * p.velocity_coef * dt
            vel = vel + add
            prev[..., :2], prev[..., 3] = add, 0.0
        for _ in range(p.gs_iterations):
            vel = boundary_velocity(diffuse_ref(vel, prev[..., :2], dt * p.visc * w * h))
        vel, prev = project_ref(vel, prev, book, sweeps)
        prev[..., :2] = vel
        if p.solver == "vol1":
            vel = boundary_velocity(advect_velocity_ref(prev, dfdt, book))
        vel, prev = project_ref(vel, prev, book, sweeps)
    if brush is not None:
        add = source[..., 2] * p.density_coef * dt
        dens = dens + add
        prev[..., 2] = add
    for _ in range(p.gs_iterations):
        dens = boundary_copy(diffuse_ref(dens, prev[..., 2], dt * p.diff * w * h))
    prev[..., 2] = dens
    carrier = (source[..., :2] if brush is not None else 0 * vel) if p.density_only else vel
    dens = boundary_copy(advect_density_ref(carrier, prev, dfdt, book))
    return {"velocity": vel, "density": dens, "prev": prev, "source": source}


def divergence_ref(vel):
    """du/dx + dv/dy by central differences, interior cells only (domain length 1 per axis)."""
    h, w = vel.shape[:2]
    u, v = vel[..., 0].astype(float), vel[..., 1].astype(float)
    return 0.5 * ((u[1:-1, 2:] - u[1:-1, :-2]) * w + (v[2:, 1:-1] - v[:-2, 1:-1]) * h)


def random_fields(rng, w, h):
    """Random velocity, density, prev and source fields of a w x h grid (float64), for set_fields."""
    return {
        "velocity": rng.uniform(-1, 1, (h, w, 2)),
        "density": rng.uniform(0, 1, (h, w)),
        "prev": rng.uniform(-1, 1, (h, w, 4)),
        "source": rng.uniform(-1, 1, (h, w, 4)),
    }
