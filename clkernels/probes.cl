// probes.cl: kernels `ugpcl bench` times to learn the device itself (ugpcl/benchmark.py), not from the book.
// LaunchProbe measures the host cost of one launch with the argument list of a typical chapter kernel (three
// buffers, four scalars), through PyOpenCL's plain call, a bare enqueue_nd_range_kernel and ugpcl's launch path.
// FmaProbe measures the FP32 peak that the chapters' flop rates are a share of: independent fused multiply-adds
// with nothing else in the loop.
// Kernels:
//   1. LaunchProbe  a, b -> out[i] = a[i] * scale + b[i] + time, for i < n
//   2. FmaProbe     out[i] = the sum of 8 float4 chains of `rounds` x 16 FMAs each (2 flops per lane and FMA)
// Build defines: none.

__kernel void LaunchProbe(const __global float* a, const __global float* b, __global float* out, int n, float scale,
                          float time, int unused) {
    int i = get_global_id(0);
    if (i >= n) return;  // the global size is padded to whole work-groups
    out[i] = a[i] * scale + b[i] + time;
}

// 8 independent float4 chains keep every FMA pipe busy; the result is written so the compiler keeps the work.
// rounds x 16 FMAs per chain: 8 chains x 4 lanes x 2 flops = 64 flops per FMA step of all chains.
__kernel void FmaProbe(__global float* out, int rounds, float a, float b) {
    int i = get_global_id(0);
    float4 x0 = (float4)(i, i + 1, i + 2, i + 3) * 1e-9f, x1 = x0 + 0.1f, x2 = x0 + 0.2f, x3 = x0 + 0.3f;
    float4 x4 = x0 + 0.4f, x5 = x0 + 0.5f, x6 = x0 + 0.6f, x7 = x0 + 0.7f;
    for (int r = 0; r < rounds; r++) {
#pragma unroll
        for (int k = 0; k < 16; k++) {
            x0 = fma(x0, a, b); x1 = fma(x1, a, b); x2 = fma(x2, a, b); x3 = fma(x3, a, b);
            x4 = fma(x4, a, b); x5 = fma(x5, a, b); x6 = fma(x6, a, b); x7 = fma(x7, a, b);
        }
    }
    float4 s = ((x0 + x1) + (x2 + x3)) + ((x4 + x5) + (x6 + x7));
    out[i] = s.x + s.y + s.z + s.w;
}
