"""numpy twin of the mcmc kernels (vol.1 ch.8): float32 noise, float64 density, the same Philox draws as the kernels
(Prepare, the density modes, Sequence), so the tests redraw any chain and compare it with the device's."""

from __future__ import annotations

import numpy as np

from ugpcl.random import philox4x32, uniform01
from ugpcl.scenes.mcmc import (
    GRID_MARGIN,
    LEGACY_RESET_INDEX,
    PURPOSE_LEGACY,
    PURPOSE_PALETTE,
    PURPOSE_RESET,
    PURPOSE_STEP_XY,
    PURPOSE_STEP_Z,
    TRUNCATION_RADIUS,
    Params,
)


def _fastfloor(n: np.ndarray) -> np.ndarray:
    t = np.trunc(n).astype(np.int32)
    return np.where(n > 0, t, t - 1)


def noise_numpy(points, T) -> np.ndarray:
    """Perlin's reference simplex noise at each point (n, 3), in float32 as the kernel computes it."""
    F = np.float32
    p = np.asarray(points, F).reshape(-1, 3)
    T = np.asarray(T, np.int64)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    s = (x + y + z) * F(0.333333333)
    i, j, k = _fastfloor(x + s), _fastfloor(y + s), _fastfloor(z + s)
    s = (i + j + k).astype(F) * F(0.166666667)
    u, v, w = x - i.astype(F) + s, y - j.astype(F) + s, z - k.astype(F) + s
    A = np.zeros((3, len(p)), np.int32)
    hi = np.where(u >= w, np.where(u >= v, 0, 1), np.where(v >= w, 1, 2))
    lo = np.where(u < w, np.where(u < v, 0, 1), np.where(v < w, 1, 2))
    rows = np.arange(len(p))

    def bit(n, b):
        return (n >> b) & 1

    def shuffle(a, b, c):
        h = np.zeros(len(p), np.int64)
        for B in range(8):
            q, r, t = ((a, b, c), (b, c, a), (c, a, b))[B % 3]
            h += T[bit(q, B) << 2 | bit(r, B) << 1 | bit(t, B)]
        return h

    def corner(a):
        s = (A[0] + A[1] + A[2]).astype(F) * F(0.166666667)
        X, Y, Z = u - A[0].astype(F) + s, v - A[1].astype(F) + s, w - A[2].astype(F) + s
        t = F(0.6) - X * X - Y * Y - Z * Z
        h = shuffle(i + A[0], j + A[1], k + A[2])
        A[a, rows] += 1
        b5, b4, b3, b2, b = (h >> 5) & 1, (h >> 4) & 1, (h >> 3) & 1, (h >> 2) & 1, h & 3
        P = np.where(b == 1, X, np.where(b == 2, Y, Z))
        Q = np.where(b == 1, Y, np.where(b == 2, Z, X))
        R = np.where(b == 1, Z, np.where(b == 2, X, Y))
        P, Q, R = np.where(b5 == b3, -P, P), np.where(b5 == b4, -Q, Q), np.where(b5 != (b4 ^ b3), -R, R)
        t2 = t * t
        value = F(8.0) * t2 * t2 * (P + np.where(b == 0, Q + R, np.where(b2 == 0, Q, R)))
        return np.where(t < 0, F(0.0), value).astype(F)

    n = corner(hi)
    n = n + corner(3 - hi - lo)
    n = n + corner(lo)
    return n + corner(np.zeros_like(hi))


def lattice_numpy(L: int, T) -> np.ndarray:
    """W[z, y, x] = noise(x, y, z): the twin of Prepare."""
    z, y, x = np.meshgrid(np.arange(L), np.arange(L), np.arange(L), indexing="ij")
    return noise_numpy(np.column_stack([x.ravel(), y.ravel(), z.ravel()]), T).reshape(L, L, L)


def density_numpy(W: np.ndarray, points, chunk: int = 4096) -> np.ndarray:
    """density=exact in float64: sum over lattice points with |x - p|^2 <= 25 of exp(-|x - p|^2) W[p]."""
    W = np.asarray(W, np.float64)
    L = W.shape[0]
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    offsets = np.arange(11)  # ceil(x - 5) .. ceil(x - 5) + 10 covers every |d| <= 5
    out = np.empty(len(pts))
    for start in range(0, len(pts), chunk):
        x = pts[start : start + chunk]
        idx = np.ceil(x - TRUNCATION_RADIUS)[:, :, None] + offsets  # (n, 3 axes, 11)
        d2 = (x[:, :, None] - idx) ** 2
        valid = (idx >= 0) & (idx <= L - 1)
        ii = np.clip(idx, 0, L - 1).astype(np.intp)
        w = W[ii[:, 2, :, None, None], ii[:, 1, None, :, None], ii[:, 0, None, None, :]]  # (n, z, y, x)
        r2 = d2[:, 2, :, None, None] + d2[:, 1, None, :, None] + d2[:, 0, None, None, :]
        mask = valid[:, 2, :, None, None] & valid[:, 1, None, :, None] & valid[:, 0, None, None, :]
        mask &= r2 <= TRUNCATION_RADIUS**2
        out[start : start + chunk] = np.where(mask, np.exp(-r2) * w, 0.0).sum(axis=(1, 2, 3))
    return out


def _draw(chains: np.ndarray, index, batch: int, purpose: int, key) -> np.ndarray:
    c = np.asarray(chains, np.uint32)
    counters = np.column_stack(
        [c, np.broadcast_to(np.asarray(index, np.uint32), c.shape), np.full_like(c, batch), np.full_like(c, purpose)]
    )
    return philox4x32(counters, key)


def _open01(bits: np.ndarray) -> np.ndarray:
    return ((bits >> np.uint32(9)).astype(np.float32) + np.float32(0.5)) * np.float32(2.0**-23)


def _box_muller(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    F = np.float32
    return np.sqrt(F(-2.0) * np.log(_open01(a))) * np.sin(F(2.0 * np.pi) * _open01(b))


def _legacy_numpy(W, x, picks, chains, index, batch, key) -> np.ndarray:
    L = W.shape[0]
    count = L**3
    total = np.zeros(len(x))
    for m in range(0, picks, 4):
        bits = _draw(chains, index, batch, PURPOSE_LEGACY + m // 4, key)
        for n in range(min(4, picks - m)):
            ids = np.floor(uniform01(bits[:, n]) * np.float32(count - 1)).astype(np.int64)
            p = np.column_stack([ids % L, (ids // L) % L, ids // (L * L)])
            total += np.exp(-((x - p) ** 2).sum(axis=1)) * W.reshape(-1)[ids]
    return total


def _grid_numpy(G, geometry, x) -> np.ndarray:
    M, origin, oversample = geometry
    F = np.float32
    g = (np.clip(x.astype(F), F(-1e6), F(1e6)) - F(origin)) * F(oversample)
    f = np.floor(g)
    i = f.astype(np.int64)
    inside = ((i >= 0) & (i < M - 1)).all(axis=1)
    i = np.clip(i, 0, M - 2)
    t = (g - f).astype(np.float64)
    out = np.zeros(len(x))
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                weight = (
                    (t[:, 0] if dx else 1 - t[:, 0])
                    * (t[:, 1] if dy else 1 - t[:, 1])
                    * (t[:, 2] if dz else 1 - t[:, 2])
                )
                out += weight * G[i[:, 2] + dz, i[:, 1] + dy, i[:, 0] + dx]
    return np.where(inside, out, 0.0)


def sequence_numpy(params: Params, W, key, chains, batch: int = 0, steps: int | None = None, grid=None) -> dict:
    """The twin of Sequence for the chain ids ``chains``: the same Philox draws, float32 proposals, float64 densities.
    ``steps`` cuts the chain short (burn-in counts); ``grid`` is the device's Dgrid for density=grid. Returns the
    arrays Sequence writes, samples (n, S', 3) holding the emitted states within ``steps``."""
    p = params
    W = np.asarray(W, np.float64)
    chains = np.asarray(chains, np.uint32)
    n = len(chains)
    mode = p.density
    geometry = ((p.L - 1 + 2 * GRID_MARGIN) * p.oversample + 1, -float(GRID_MARGIN), float(p.oversample))

    def density(x, index):
        if mode == "legacy":
            return _legacy_numpy(W, x, p.legacy_picks, chains, index, batch, key)
        if mode == "grid":
            return _grid_numpy(np.asarray(grid, np.float64), geometry, x)
        if mode == "gaussian":
            d = x - np.asarray(p.target_mean)
            return np.exp(-(d * d).sum(axis=1) / (2 * np.float32(p.target_sigma) ** 2))
        return density_numpy(W, x)

    palette = ((_draw(chains, 0, batch, PURPOSE_PALETTE, key)[:, 0].astype(np.uint64) * 9) >> 32).astype(np.uint8)
    cur = np.zeros((n, 3), np.float32)
    cur_d = np.zeros(n)
    tries = np.zeros(n, np.uint32)
    for t in range(p.reset_limit):
        active = cur_d <= 0
        if not active.any():
            break
        u = uniform01(_draw(chains, t, batch, PURPOSE_RESET, key))[:, :3]
        start = np.float32(p.L) * u
        d = density(start, LEGACY_RESET_INDEX + t)
        cur[active], cur_d[active] = start[active], d[active]
        tries[active] += 1
    init_density = cur_d.copy()
    lc = p.cholesky().astype(np.float32)
    total = p.burn_in + p.samples if steps is None else steps
    emitted, accepted = [], np.zeros(n, np.uint32)
    for s in range(total):
        if s >= p.burn_in:
            emitted.append(cur.copy())
        xy = _draw(chains, s, batch, PURPOSE_STEP_XY, key)
        zu = _draw(chains, s, batch, PURPOSE_STEP_Z, key)
        z = np.column_stack(
            [_box_muller(xy[:, 0], xy[:, 1]), _box_muller(xy[:, 2], xy[:, 3]), _box_muller(zu[:, 0], zu[:, 1])]
        )
        nxt = cur + z @ lc.T
        nd = density(nxt, s)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.minimum(1.0, nd / np.where(cur_d > 0, cur_d, 1.0))
        keep = ((cur_d <= 0) | (ratio >= _open01(zu[:, 2]))) & (nd > np.float32(p.threshold))
        cur[keep], cur_d[keep] = nxt[keep], nd[keep]
        accepted += keep
    samples = np.stack(emitted, axis=1) if emitted else np.zeros((n, 0, 3), np.float32)
    return {
        "samples": samples,
        "accepted": accepted,
        "reset_tries": tries,
        "init_density": init_density,
        "palette": palette,
    }
