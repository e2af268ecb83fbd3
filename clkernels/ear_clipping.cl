// ear_clipping.cl: Unity Graphics Programming vol.4 ch.5, "Triangulation by Ear Clipping"
// (docs/chapters/16-ear-clipping.md). The book clips one polygon on the CPU (Triangulation.cs); this file clips many
// small ones at once, one work-item per polygon, with the book's ear rule. Host: ugpcl/scenes/ear_clipping.py
// (ear_clip_batch); the host twin of every step is ugpcl/geometry/ear_clipping.py (EarClipper).
// Kernels, in host call order:
//   1. EarClipping  points, offsets -> triangles, triangle_counts: per polygon the book's InitializeVertices (the
//                   first FIFO ear list), then EarClipping (emit the head ear's (prev, ear, next), unlink it,
//                   CheckVertex on both neighbours) until 3 vertices are left or the ear list runs dry
//   2. EarClippingLarge  points -> triangles, result: one polygon of any size by one work-item (the robust clipper,
//                   the ring, the ear list and a grid of the vertices in global memory; see its section below)
// Build defines: MAX_VERTICES = the most vertices one polygon may have (ugpcl: 64); the index ring and the ear list
// live in private arrays of that length. ROBUST = 1 for the robust default's clipper (not in the book; the host's
// EarClipper(robust=True)): a vertex at an ear's corner blocks it when the ring enters the triangle there, and
// vertices where the ring turns back on itself (spike tips, repeated points) are dropped without a triangle.
// Input: polygons that are already simple and clockwise (y up), holes bridged in by the host (CombinePolygon).
// Output: polygon i writes its triangles from row offsets[i] - 2 i (n - 2 rows at most), as indices into points;
// triangle_counts[i] = rows written (n - 2 when complete, fewer if the ear list ran dry or, ROBUST, flat vertices
// were dropped; 0 for n < 3 or too large); finished[i] = 1 when the polygon is covered (the last triangle is out).
// Atomics: none. Races: none (every work-item writes only its own rows).
// Differences from the book: none in the arithmetic. It is float64 with FP_CONTRACT off, so every orientation sign
// is the host's bit for bit and both give the same triangles in the same order (tests/test_ear_clipping.py).
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF  // a fused a*b - c*d would round differently from the host's numpy

#ifndef ROBUST
#define ROBUST 0
#endif
#ifndef MAX_VERTICES
#error "build with -D MAX_VERTICES=<largest polygon, at most 256>"
#endif
#if MAX_VERTICES > 256
#error "MAX_VERTICES must fit the uchar ring indices"
#endif

// IsAngleLessPI: the interior angle at `now` of a clockwise ring is below 180 degrees (collinear: reflex)
inline bool is_convex(double2 now, double2 prev, double2 next) {
    return (prev.x - now.x) * (next.y - now.y) - (prev.y - now.y) * (next.x - now.x) > 0.0;
}

// CheckLine(o, p1, p2) >= 0: o on or right of the line p1 -> p2 (inside or on a clockwise triangle's edge)
inline bool right_of(double2 o, double2 p1, double2 p2) {
    return (o.x - p1.x) * (p2.y - p1.y) - (p2.x - p1.x) * (o.y - p1.y) >= 0.0;
}

inline bool same_point(double2 a, double2 b) { return a.x == b.x && a.y == b.y; }

inline double cross2(double2 u, double2 w) { return u.x * w.y - u.y * w.x; }

#if ROBUST
// The pre-pass's in_cone, for this clockwise ring read backwards (region on the left): `target` seen from `at`
// lies strictly inside the region's angle between the ring's neighbours `before` and `after`.
inline bool in_cone(double2 before, double2 at, double2 after, double2 target) {
    const double2 prev = after, nxt = before;  // backwards
    if (cross2(at - prev, nxt - prev) > 0.0)
        return cross2(target - at, prev - at) > 0.0 && cross2(at - target, nxt - target) > 0.0;
    return !(cross2(target - at, nxt - at) >= 0.0 && cross2(at - target, prev - target) >= 0.0);
}

// EarClipper.corner_blocks: vertex k at the coordinates of corner `corner` of the clockwise triangle
// (corner, after, before) blocks the ear when the new edge does not leave the corner inside its own angle, or one
// of k's edges goes into the triangle's open angle there.
inline bool corner_blocks(const __global double2* pts, const uchar* prev, const uchar* next, int k, int corner,
                          int after, int before, int v, int p, int q) {
    const double2 at = pts[corner];
    if (corner != v) {
        const int target = corner == p ? q : p;
        const double2 b0 = pts[prev[corner]], a0 = pts[next[corner]];
        if (same_point(b0, at) || same_point(a0, at) || !in_cone(b0, at, a0, pts[target])) return true;
    }
    const double2 u = pts[after] - at, w = at - pts[before];
    const double2 d1 = pts[prev[k]] - at, d2 = pts[next[k]] - at;
    return (cross2(u, d1) < 0.0 && cross2(w, d1) < 0.0) || (cross2(u, d2) < 0.0 && cross2(w, d2) < 0.0);
}
#endif

// The ear test of CheckVertex: -1 reflex; 0 convex but another live vertex lies in or on the triangle
// (prev, v, next); 1 an ear. Vertices at a corner's coordinates (bridge copies) do not block, as in the book
// (ROBUST: unless corner_blocks).
inline int ear_state(const __global double2* pts, const uchar* prev, const uchar* next, int v) {
    const int p = prev[v], q = next[v];
    const double2 a = pts[p], b = pts[v], c = pts[q];
    if (!is_convex(b, a, c)) return -1;
    for (int k = next[q]; k != p; k = next[k]) {  // every live vertex but p, v, q
        const double2 o = pts[k];
        if (!(right_of(o, b, c) && right_of(o, c, a) && right_of(o, a, b))) continue;  // IsInTriangle > 0
#if ROBUST
        if (same_point(o, a)) { if (corner_blocks(pts, prev, next, k, p, v, q, v, p, q)) return 0; continue; }
        if (same_point(o, b)) { if (corner_blocks(pts, prev, next, k, v, q, p, v, p, q)) return 0; continue; }
        if (same_point(o, c)) { if (corner_blocks(pts, prev, next, k, q, p, v, v, p, q)) return 0; continue; }
#else
        if (same_point(o, a) || same_point(o, b) || same_point(o, c)) continue;
#endif
        return 0;
    }
    return 1;
}

#if ROBUST
// EarClipper._flat: the ring turns back on itself at v (a spike's tip, a repeated point); straight: or runs on
inline bool flat(const __global double2* pts, const uchar* prev, const uchar* next, int v, bool straight) {
    const double2 a = pts[prev[v]], b = pts[v], c = pts[next[v]];
    return cross2(b - a, c - a) == 0.0 && (straight || dot(a - b, c - b) >= 0.0);
}
#endif

// CheckVertex: a convex vertex joins the end of the ear list or leaves it (in place); a reflex one changes nothing
inline void check_vertex(const __global double2* pts, const uchar* prev, const uchar* next, uchar* ears,
                         int* ear_count, bool* listed, int v) {
    int state = ear_state(pts, prev, next, v);
    if (ROBUST && state == -1) state = 0;  // no longer convex: it leaves the list (the book keeps it)
    if (state == 1 && !listed[v]) {
        ears[(*ear_count)++] = (uchar)v;
        listed[v] = true;
    } else if (state == 0 && listed[v]) {
        int k = 0;
        while (ears[k] != v) k++;
        for (; k + 1 < *ear_count; k++) ears[k] = ears[k + 1];
        (*ear_count)--;
        listed[v] = false;
    }
}

// Unlink v from the ring and the ear list (EarClipper._remove)
inline void remove_vertex(uchar* prev, uchar* next, uchar* ears, int* ear_count, bool* listed, bool* alive,
                          int* count, int v) {
    if (listed[v]) {
        int k = 0;
        while (ears[k] != v) k++;
        for (; k + 1 < *ear_count; k++) ears[k] = ears[k + 1];
        (*ear_count)--;
        listed[v] = false;
    }
    next[prev[v]] = next[v];
    prev[next[v]] = prev[v];
    alive[v] = false;
    (*count)--;
}

__kernel void EarClipping(const __global double2* points, const __global int* offsets, __global int* triangles,
                          __global int* triangle_counts, __global uchar* finished, const int polygon_count) {
    const int i = get_global_id(0);
    if (i >= polygon_count) return;  // no barriers: padding work-items just leave
    const int first = offsets[i];
    const int n = offsets[i + 1] - first;
    const __global double2* pts = points + first;
    __global int* out = triangles + 3 * (first - 2 * i);  // n - 2 rows per polygon before this one
    int emitted = 0;
    bool done = false;
    if (n >= 3 && n <= MAX_VERTICES) {
        uchar prev[MAX_VERTICES], next[MAX_VERTICES], ears[MAX_VERTICES];  // LinkedList<int> indices, earTipList
        bool listed[MAX_VERTICES], alive[MAX_VERTICES];
        int ear_count = 0, count = n;
        // InitializeVertices
        for (int v = 0; v < n; v++) {
            prev[v] = (uchar)(v == 0 ? n - 1 : v - 1);
            next[v] = (uchar)(v == n - 1 ? 0 : v + 1);
            listed[v] = false;
            alive[v] = true;
        }
#if ROBUST
        for (bool changed = true; changed && count > 3;) {  // passes in index order until none is flat
            changed = false;
            for (int v = 0; v < n; v++) {
                if (count > 3 && alive[v] && flat(pts, prev, next, v, false)) {
                    remove_vertex(prev, next, ears, &ear_count, listed, alive, &count, v);
                    changed = true;
                }
            }
        }
        int any = 0;
        while (!alive[any]) any++;
        done = count == 3 && flat(pts, prev, next, any, true);  // what is left covers nothing
        if (!done)
#endif
            for (int v = 0; v < n; v++)
                if (alive[v]) check_vertex(pts, prev, next, ears, &ear_count, listed, v);
        // EarClipping
        while (ear_count > 0) {
            const int e = ears[0];
            int p = prev[e], q = next[e];
            out[3 * emitted + 0] = first + p;
            out[3 * emitted + 1] = first + e;
            out[3 * emitted + 2] = first + q;
            emitted++;
            if (count == 3) {  // the last triangle
                done = true;
                break;
            }
            remove_vertex(prev, next, ears, &ear_count, listed, alive, &count, e);
#if ROBUST
            while (count > 3) {  // the ring turning back on itself at p or q is dropped
                int gone;
                if (flat(pts, prev, next, p, false)) {
                    gone = p;
                    p = prev[p];
                } else if (flat(pts, prev, next, q, false)) {
                    gone = q;
                    q = next[q];
                } else {
                    break;
                }
                remove_vertex(prev, next, ears, &ear_count, listed, alive, &count, gone);
            }
            if (count == 3 && flat(pts, prev, next, p, true)) {
                done = true;
                break;
            }
#endif
            check_vertex(pts, prev, next, ears, &ear_count, listed, p);
            check_vertex(pts, prev, next, ears, &ear_count, listed, q);
        }
    }
    triangle_counts[i] = emitted;
    finished[i] = done;
}

// {{{ EarClippingLarge: one large polygon, one work-item (not in the book; meant for CPU devices)
//
// The robust clipper of EarClipping for a polygon of any size: the ring, the FIFO ear list and a grid of the
// vertices live in global memory, and the ear test reads only the vertices in the grid cells around the ear's
// triangle (grown by 1/1024 of its longer side) instead of every live vertex. Host: ear_clip_large
// (ugpcl/scenes/ear_clipping.py), which fills cell_head with -1; the host twin is EarClipper(robust=True).
// Output: triangles (n - 2 rows at most), result[0] = rows written, result[1] = 1 when the polygon is covered.

#define NONE (-1)

inline bool large_convex(const __global double2* pts, const __global int* prev, const __global int* next, int v) {
    return is_convex(pts[v], pts[prev[v]], pts[next[v]]);
}

// EarClipper._flat: the ring turns back on itself at v; straight: or runs on
inline bool large_flat(const __global double2* pts, const __global int* prev, const __global int* next, int v,
                       bool straight) {
    const double2 a = pts[prev[v]], b = pts[v], c = pts[next[v]];
    return cross2(b - a, c - a) == 0.0 && (straight || dot(a - b, c - b) >= 0.0);
}

// in_cone read backwards, as above, on the global ring
inline bool large_in_cone(double2 before, double2 at, double2 after, double2 target) {
    const double2 prev = after, nxt = before;
    if (cross2(at - prev, nxt - prev) > 0.0)
        return cross2(target - at, prev - at) > 0.0 && cross2(at - target, nxt - target) > 0.0;
    return !(cross2(target - at, nxt - at) >= 0.0 && cross2(at - target, prev - target) >= 0.0);
}

inline bool large_corner_blocks(const __global double2* pts, const __global int* prev, const __global int* next,
                                int k, int corner, int after, int before, int v, int p, int q) {
    const double2 at = pts[corner];
    if (corner != v) {
        const int target = corner == p ? q : p;
        const double2 b0 = pts[prev[corner]], a0 = pts[next[corner]];
        if (same_point(b0, at) || same_point(a0, at) || !large_in_cone(b0, at, a0, pts[target])) return true;
    }
    const double2 u = pts[after] - at, w = at - pts[before];
    const double2 d1 = pts[prev[k]] - at, d2 = pts[next[k]] - at;
    return (cross2(u, d1) < 0.0 && cross2(w, d1) < 0.0) || (cross2(u, d2) < 0.0 && cross2(w, d2) < 0.0);
}

// The ear test: -1 reflex, 0 blocked, 1 an ear (the vertices of the grid cells around the triangle)
inline int large_ear_state(const __global double2* pts, const __global int* prev, const __global int* next,
                           const __global uchar* alive, const __global int* cell_head, const __global int* cell_next,
                           const double2 lo, const double inv_cell, const int grid, int v) {
    const int p = prev[v], q = next[v];
    const double2 a = pts[p], b = pts[v], c = pts[q];
    if (!is_convex(b, a, c)) return -1;
    const double2 box_lo = fmin(fmin(a, b), c), box_hi = fmax(fmax(a, b), c);
    const double grow = fmax(box_hi.x - box_lo.x, box_hi.y - box_lo.y) * (1.0 / 1024.0);
    const int i0 = clamp((int)floor((box_lo.x - grow - lo.x) * inv_cell), 0, grid - 1);
    const int i1 = clamp((int)floor((box_hi.x + grow - lo.x) * inv_cell), 0, grid - 1);
    const int j0 = clamp((int)floor((box_lo.y - grow - lo.y) * inv_cell), 0, grid - 1);
    const int j1 = clamp((int)floor((box_hi.y + grow - lo.y) * inv_cell), 0, grid - 1);
    for (int j = j0; j <= j1; j++) {
        for (int i = i0; i <= i1; i++) {
            for (int k = cell_head[j * grid + i]; k != NONE; k = cell_next[k]) {
                if (!alive[k] || k == p || k == v || k == q) continue;
                const double2 o = pts[k];
                if (!(right_of(o, b, c) && right_of(o, c, a) && right_of(o, a, b))) continue;
                if (same_point(o, a)) { if (large_corner_blocks(pts, prev, next, k, p, v, q, v, p, q)) return 0; continue; }
                if (same_point(o, b)) { if (large_corner_blocks(pts, prev, next, k, v, q, p, v, p, q)) return 0; continue; }
                if (same_point(o, c)) { if (large_corner_blocks(pts, prev, next, k, q, p, v, v, p, q)) return 0; continue; }
                return 0;
            }
        }
    }
    return 1;
}

// the FIFO ear list, linked through ear_next / ear_prev; index n is its head and tail sentinel
inline void large_append(__global int* ear_next, __global int* ear_prev, __global uchar* listed, int n, int v) {
    const int tail = ear_prev[n];
    ear_next[tail] = v;
    ear_prev[v] = tail;
    ear_next[v] = n;
    ear_prev[n] = v;
    listed[v] = 1;
}

inline void large_unlist(__global int* ear_next, __global int* ear_prev, __global uchar* listed, int v) {
    const int before = ear_prev[v], after = ear_next[v];
    ear_next[before] = after;
    ear_prev[after] = before;
    listed[v] = 0;
}

__kernel void EarClippingLarge(const __global double2* pts, const int n, __global int* prev, __global int* next,
                               __global int* ear_next, __global int* ear_prev, __global uchar* listed,
                               __global uchar* alive, __global int* cell_head, __global int* cell_next,
                               const double2 lo, const double inv_cell, const int grid, __global int* triangles,
                               __global int* result) {
    if (get_global_id(0) != 0) return;
    for (int v = 0; v < n; v++) {
        prev[v] = v == 0 ? n - 1 : v - 1;
        next[v] = v == n - 1 ? 0 : v + 1;
        listed[v] = 0;
        alive[v] = 1;
        const int i = clamp((int)floor((pts[v].x - lo.x) * inv_cell), 0, grid - 1);
        const int j = clamp((int)floor((pts[v].y - lo.y) * inv_cell), 0, grid - 1);
        cell_next[v] = cell_head[j * grid + i];
        cell_head[j * grid + i] = v;
    }
    ear_next[n] = ear_prev[n] = n;
    int count = n, emitted = 0;
    bool done = n < 3;
#define REMOVE(v)                                                   \
    do {                                                            \
        if (listed[v]) large_unlist(ear_next, ear_prev, listed, v); \
        next[prev[v]] = next[v];                                    \
        prev[next[v]] = prev[v];                                    \
        alive[v] = 0;                                               \
        count--;                                                    \
    } while (0)
#define CHECK(v)                                                                                               \
    do {                                                                                                       \
        const int state = large_ear_state(pts, prev, next, alive, cell_head, cell_next, lo, inv_cell, grid, v); \
        if (state == 1 && !listed[v]) large_append(ear_next, ear_prev, listed, n, v);                          \
        else if (state != 1 && listed[v]) large_unlist(ear_next, ear_prev, listed, v);                         \
    } while (0)
    if (!done) {
        for (bool changed = true; changed && count > 3;) {  // passes in index order until none is flat
            changed = false;
            for (int v = 0; v < n; v++) {
                if (count > 3 && alive[v] && large_flat(pts, prev, next, v, false)) {
                    REMOVE(v);
                    changed = true;
                }
            }
        }
        int any = 0;
        while (!alive[any]) any++;
        done = count == 3 && large_flat(pts, prev, next, any, true);
    }
    if (!done)
        for (int v = 0; v < n; v++)
            if (alive[v]) CHECK(v);
    while (!done && ear_next[n] != n) {
        const int e = ear_next[n];
        int p = prev[e], q = next[e];
        triangles[3 * emitted + 0] = p;
        triangles[3 * emitted + 1] = e;
        triangles[3 * emitted + 2] = q;
        emitted++;
        if (count == 3) {
            done = true;
            break;
        }
        REMOVE(e);
        while (count > 3) {
            int gone;
            if (large_flat(pts, prev, next, p, false)) {
                gone = p;
                p = prev[p];
            } else if (large_flat(pts, prev, next, q, false)) {
                gone = q;
                q = next[q];
            } else {
                break;
            }
            REMOVE(gone);
        }
        if (count == 3 && large_flat(pts, prev, next, p, true)) {
            done = true;
            break;
        }
        CHECK(p);
        CHECK(q);
    }
#undef REMOVE
#undef CHECK
    result[0] = emitted;
    result[1] = done;
}

// }}}
