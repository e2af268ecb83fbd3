"""Exact orientation signs for float64 points: a rounding-error filter first (Shewchuk's bound for ``orient2d``), the
few uncertain cases recomputed in rational arithmetic (``fractions.Fraction`` holds every finite float exactly).

``orient(a, b, c)`` is +1 when c lies left of the line a -> b (a, b, c counter-clockwise, y up), -1 right, 0 on it:
the sign of (b - a) x (c - a), exactly, whatever the coordinates' magnitudes. The robust ear clipping pipeline
decides orientation, nesting, bridges and touching points with it, so a vertex exactly on an edge is on it and one a
hair off is off.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

EPSILON = 2.0**-53
"""Unit roundoff of float64."""
ORIENT_BOUND = (3.0 + 16.0 * EPSILON) * EPSILON
"""|det - exact| <= this x (|(a-c).x (b-c).y| + |(a-c).y (b-c).x|) (Shewchuk, ccwerrboundA)."""


def _exact(ax, ay, bx, by, cx, cy) -> int:
    ax, ay, bx, by, cx, cy = map(Fraction, (ax, ay, bx, by, cx, cy))
    det = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
    return (det > 0) - (det < 0)


def orient(a, b, c) -> int:
    """Sign of (b - a) x (c - a): +1 counter-clockwise, -1 clockwise, 0 collinear (exact)."""
    left = (a[0] - c[0]) * (b[1] - c[1])
    right = (a[1] - c[1]) * (b[0] - c[0])
    det = left - right
    bound = ORIENT_BOUND * (abs(left) + abs(right))
    if det > bound:
        return 1
    if -det > bound:
        return -1
    if (a[0] == c[0] or b[1] == c[1]) and (a[1] == c[1] or b[0] == c[0]):
        return 0  # both products are exactly zero
    return _exact(float(a[0]), float(a[1]), float(b[0]), float(b[1]), float(c[0]), float(c[1]))


def orient_many(ax, ay, bx, by, cx, cy) -> np.ndarray:
    """``orient`` over arrays (broadcast): int8 signs."""
    ax, ay, bx, by, cx, cy = np.broadcast_arrays(*(np.asarray(v, np.float64) for v in (ax, ay, bx, by, cx, cy)))
    left = (ax - cx) * (by - cy)
    right = (ay - cy) * (bx - cx)
    det = left - right
    bound = ORIENT_BOUND * (np.abs(left) + np.abs(right))
    sign = np.sign(det).astype(np.int8)
    zero = ((ax == cx) | (by == cy)) & ((ay == cy) | (bx == cx))
    sign[zero] = 0
    for i in np.flatnonzero(~zero & ~(np.abs(det) > bound)).tolist():
        sign.flat[i] = _exact(ax.flat[i], ay.flat[i], bx.flat[i], by.flat[i], cx.flat[i], cy.flat[i])
    return sign


def twice_area(ring: np.ndarray) -> Fraction:
    """Twice the signed (shoelace) area of a ring, exactly: > 0 counter-clockwise."""
    xs = [Fraction(float(v)) for v in ring[:, 0]]
    ys = [Fraction(float(v)) for v in ring[:, 1]]
    n = len(xs)
    return sum((xs[i] * ys[(i + 1) % n] - xs[(i + 1) % n] * ys[i] for i in range(n)), Fraction(0))


def ring_sign(ring: np.ndarray) -> int:
    """The sign of a ring's signed area (+1 counter-clockwise), exact; float64 decides when far from zero."""
    x, y = ring[:, 0], ring[:, 1]
    forward, backward = x * np.roll(y, -1), np.roll(x, -1) * y
    total = float((forward - backward).sum())
    bound = (len(ring) + 2) * EPSILON * float((np.abs(forward) + np.abs(backward)).sum())
    if abs(total) > 2.0 * bound + 1e-300:
        return 1 if total > 0 else -1
    area = twice_area(ring)
    return (area > 0) - (area < 0)
