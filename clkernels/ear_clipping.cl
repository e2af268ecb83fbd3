// ear_clipping.cl: Unity Graphics Programming vol.4 ch.5, "Triangulation by Ear Clipping"
// (docs/chapters/16-ear-clipping.md). The book clips one polygon on the CPU (Triangulation.cs); this file clips many
// small ones at once, one work-item per polygon, with the book's ear rule. Host: ugpcl/scenes/ear_clipping.py
// (ear_clip_batch); the host twin of every step is ugpcl/geometry/ear_clipping.py (EarClipper).
// Kernels, in host call order:
//   1. EarClipping  points, offsets -> triangles, triangle_counts: per polygon the book's InitializeVertices (the
//                   first FIFO ear list), then EarClipping (emit the head ear's (prev, ear, next), unlink it,
//                   CheckVertex on both neighbours) until 3 vertices are left or the ear list runs dry
// Build defines: MAX_VERTICES = the most vertices one polygon may have (ugpcl: 64); the index ring and the ear list
// live in private arrays of that length.
// Input: polygons that are already simple and clockwise (y up), holes bridged in by the host (CombinePolygon).
// Output: polygon i writes its triangles from row offsets[i] - 2 i (n - 2 rows at most), as indices into points;
// triangle_counts[i] = rows written (n - 2 when complete, fewer if the ear list ran dry, 0 for n < 3 or too large).
// Atomics: none. Races: none (every work-item writes only its own rows).
// Differences from the book: none in the arithmetic. It is float64 with FP_CONTRACT off, so every orientation sign
// is the host's bit for bit and both give the same triangles in the same order (tests/test_ear_clipping.py).
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF  // a fused a*b - c*d would round differently from the host's numpy

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

// The ear test of CheckVertex: -1 reflex; 0 convex but another live vertex lies in or on the triangle
// (prev, v, next); 1 an ear. Vertices at a corner's coordinates (bridge copies) do not block, as in the book.
inline int ear_state(const __global double2* pts, const uchar* prev, const uchar* next, int v) {
    const int p = prev[v], q = next[v];
    const double2 a = pts[p], b = pts[v], c = pts[q];
    if (!is_convex(b, a, c)) return -1;
    for (int k = next[q]; k != p; k = next[k]) {  // every live vertex but p, v, q
        const double2 o = pts[k];
        if (same_point(o, a) || same_point(o, b) || same_point(o, c)) continue;
        if (right_of(o, b, c) && right_of(o, c, a) && right_of(o, a, b)) return 0;  // IsInTriangle <= 0
    }
    return 1;
}

// CheckVertex: a convex vertex joins the end of the ear list or leaves it (in place); a reflex one changes nothing
inline void check_vertex(const __global double2* pts, const uchar* prev, const uchar* next, uchar* ears,
                         int* ear_count, bool* listed, int v) {
    const int state = ear_state(pts, prev, next, v);
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

__kernel void EarClipping(const __global double2* points, const __global int* offsets, __global int* triangles,
                          __global int* triangle_counts, const int polygon_count) {
    const int i = get_global_id(0);
    if (i >= polygon_count) return;  // no barriers: padding work-items just leave
    const int first = offsets[i];
    const int n = offsets[i + 1] - first;
    const __global double2* pts = points + first;
    __global int* out = triangles + 3 * (first - 2 * i);  // n - 2 rows per polygon before this one
    int emitted = 0;
    if (n >= 3 && n <= MAX_VERTICES) {
        uchar prev[MAX_VERTICES], next[MAX_VERTICES], ears[MAX_VERTICES];  // LinkedList<int> indices, earTipList
        bool listed[MAX_VERTICES];
        int ear_count = 0, count = n;
        // InitializeVertices
        for (int v = 0; v < n; v++) {
            prev[v] = (uchar)(v == 0 ? n - 1 : v - 1);
            next[v] = (uchar)(v == n - 1 ? 0 : v + 1);
            listed[v] = false;
        }
        for (int v = 0; v < n; v++) check_vertex(pts, prev, next, ears, &ear_count, listed, v);
        // EarClipping
        while (ear_count > 0) {
            const int e = ears[0], p = prev[e], q = next[e];
            out[3 * emitted + 0] = first + p;
            out[3 * emitted + 1] = first + e;
            out[3 * emitted + 2] = first + q;
            emitted++;
            if (count == 3) break;  // the last triangle
            for (int k = 0; k + 1 < ear_count; k++) ears[k] = ears[k + 1];  // pop the head
            ear_count--;
            listed[e] = false;
            next[p] = (uchar)q;
            prev[q] = (uchar)p;
            count--;
            check_vertex(pts, prev, next, ears, &ear_count, listed, p);
            check_vertex(pts, prev, next, ears, &ear_count, listed, q);
        }
    }
    triangle_counts[i] = emitted;
}
