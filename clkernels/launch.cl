// launch.cl: the kernel that `ugpcl bench launch` times (ugpcl/benchmark.py, bench_launch). Not from the book: it
// measures the host cost of one launch with the argument list of a typical chapter kernel (three buffers, four
// scalars), through PyOpenCL's plain call, a bare enqueue_nd_range_kernel, and ugpcl's launch path.
// Kernels:
//   1. LaunchProbe  a, b -> out[i] = a[i] * scale + b[i] + time, for i < n
// Build defines: none.

__kernel void LaunchProbe(const __global float* a, const __global float* b, __global float* out, int n, float scale,
                          float time, int unused) {
    int i = get_global_id(0);
    if (i >= n) return;  // the global size is padded to whole work-groups
    out[i] = a[i] * scale + b[i] + time;
}
