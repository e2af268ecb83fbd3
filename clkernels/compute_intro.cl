// compute_intro.cl: Unity Graphics Programming vol.1 ch.2, "Getting started with compute shaders"
// (docs/chapters/02-compute-intro.md).
//
// HLSL -> OpenCL, as used throughout ugpcl:
//   [numthreads(tx,ty,tz)]       __attribute__((reqd_work_group_size(tx,ty,tz)))
//   Dispatch(gx,gy,gz)           global size (gx*tx, gy*ty, gz*tz), local size (tx,ty,tz)
//   SV_GroupID                   get_group_id(d)
//   SV_GroupThreadID             get_local_id(d)
//   SV_DispatchThreadID          get_global_id(d) = group * numthreads + local (zero global offset)
//   SV_GroupIndex                z*tx*ty + y*tx + x of the local id
//   groupshared + GroupMemoryBarrierWithGroupSync   __local + barrier(CLK_LOCAL_MEM_FENCE)  (used in boids.cl)
//   RWStructuredBuffer<T>        __global T*          RWTexture2D<float4>   image2d_t + write_imagef
//   SetInt / SetBuffer           kernel arguments     GetData               enqueue_copy to the host
//
// The book's two samples are two .compute files; here they are the two sections of this file, chosen with
// -D SAMPLE=SAMPLE_ARRAY or SAMPLE_TEXTURE so that both keep the book's kernel names.
// Kernels, in host call order:
//   -D SAMPLE=SAMPLE_ARRAY (SimpleComputeShader_Array.compute):
//     1. KernelFunction_A         intBuffer[local id] = local id * intValue
//     2. KernelFunction_B         intBuffer[local id] += 1   (a race if > 1 group: the lesson)
//        KernelFunction_B_atomic  the same with atomic_add: exactly +1 per group
//   -D SAMPLE=SAMPLE_TEXTURE (SimpleComputeShader_Texture.compute):
//     1. KernelFunction_A         texel (x, y) = x / width   (horizontal gradient)
//     2. KernelFunction_B         texel (x, y) = y / width   (vertical; the book divides y by the width)
//        KernelFunction_A_1D      KernelFunction_A from a 1-D launch: x = id % W, y = id / W
//        DispatchProbe            every work-item's group/local/global ids (any launch shape)
// Build defines: SAMPLE; for the texture sample TX, TY (numthreads, book: 8, 8) and USE_IMAGES (1: image2d_t,
// 0: a row-major uchar4 buffer for devices without images, rounding like write_imagef).
#define SAMPLE_ARRAY 1
#define SAMPLE_TEXTURE 2
#ifndef SAMPLE
#error "build with -D SAMPLE=SAMPLE_ARRAY or -D SAMPLE=SAMPLE_TEXTURE"
#endif

#if SAMPLE == SAMPLE_ARRAY  // {{{ SimpleComputeShader_Array.compute

__kernel __attribute__((reqd_work_group_size(4, 1, 1)))
void KernelFunction_A(__global int* intBuffer, int intValue) {
    const int group_thread_id = get_local_id(0);  // SV_GroupThreadID.x: 0..3 in every group
    intBuffer[group_thread_id] = group_thread_id * intValue;
}

// RACE (book): with more than one group every group updates elements 0..3; the chapter's lesson on local ids.
__kernel __attribute__((reqd_work_group_size(4, 1, 1)))
void KernelFunction_B(__global int* intBuffer) {
    intBuffer[get_local_id(0)] += 1;
}

__kernel __attribute__((reqd_work_group_size(4, 1, 1)))
void KernelFunction_B_atomic(volatile __global int* intBuffer) {
    atomic_add(&intBuffer[get_local_id(0)], 1);  // old value unused: each group adds exactly 1
}

#elif SAMPLE == SAMPLE_TEXTURE  // }}} {{{ SimpleComputeShader_Texture.compute

#if !defined(TX) || !defined(TY) || !defined(USE_IMAGES)
#error "the texture sample needs -D TX=, -D TY= (numthreads) and -D USE_IMAGES=0|1"
#endif

#if USE_IMAGES
#define TEXTURE_ARG __write_only image2d_t textureBuffer
#define TEXTURE_WIDTH get_image_width(textureBuffer)    // HLSL GetDimensions
#define TEXTURE_HEIGHT get_image_height(textureBuffer)
#define WRITE_TEXEL(x, y, v) write_imagef(textureBuffer, (int2)((x), (y)), (v))  // UNORM8: round half to even
#else
#define TEXTURE_ARG __global uchar4* textureBuffer, int textureWidth, int textureHeight
#define TEXTURE_WIDTH textureWidth
#define TEXTURE_HEIGHT textureHeight
#define WRITE_TEXEL(x, y, v) (textureBuffer[(y) * textureWidth + (x)] = convert_uchar4_sat_rte((v) * 255.0f))
#endif

__kernel __attribute__((reqd_work_group_size(TX, TY, 1)))
void KernelFunction_A(TEXTURE_ARG) {
    const int x = get_global_id(0), y = get_global_id(1);  // SV_DispatchThreadID.xy
    const int width = TEXTURE_WIDTH, height = TEXTURE_HEIGHT;
    if (x >= width || y >= height) return;  // the global size is rounded up to whole groups
    const float v = x / (float)width;
    WRITE_TEXEL(x, y, (float4)(v, v, v, 1.0f));
}

__kernel __attribute__((reqd_work_group_size(TX, TY, 1)))
void KernelFunction_B(TEXTURE_ARG) {
    const int x = get_global_id(0), y = get_global_id(1);
    const int width = TEXTURE_WIDTH, height = TEXTURE_HEIGHT;
    if (x >= width || y >= height) return;
    const float v = y / (float)width;  // book: y over the *width*; the same as the height for its square texture
    WRITE_TEXEL(x, y, (float4)(v, v, v, 1.0f));
}

// The chapter's counter-example (2.3.7): one dimension of W*H work-items; "the 513th pixel is (0, 1)".
__kernel void KernelFunction_A_1D(TEXTURE_ARG) {
    const int id = get_global_id(0);
    const int width = TEXTURE_WIDTH, height = TEXTURE_HEIGHT;
    if (id >= width * height) return;
    const int x = id % width, y = id / width;
    const float v = x / (float)width;
    WRITE_TEXEL(x, y, (float4)(v, v, v, 1.0f));
}

// Ten ints per work-item, at its flat global index: group id xyz, local id xyz, global id xyz, SV_GroupIndex.
__kernel void DispatchProbe(__global int* probe) {
    const int flat = (get_global_id(2) * get_global_size(1) + get_global_id(1)) * get_global_size(0) + get_global_id(0);
    __global int* out = probe + 10 * flat;
    for (int d = 0; d < 3; d++) {
        out[d] = get_group_id(d);
        out[3 + d] = get_local_id(d);
        out[6 + d] = get_global_id(d);
    }
    out[9] = (get_local_id(2) * get_local_size(1) + get_local_id(1)) * get_local_size(0) + get_local_id(0);
}

#endif  // }}}
