// multiplane_projection.cl: Unity Graphics Programming vol.1 ch.9, "MultiPlane Perspective Projection"
// (docs/chapters/09-multiplane-projection.md). Host: ugpcl/scenes/multiplane_projection.py (Simulation).
// The book has no shader code: its five face cameras render a city with Unity. Here a small analytic world (a
// checkered ground plane, boxes and spheres as signed distance functions, a sky gradient) is ray-marched per pixel
// through the same off-axis cameras, which gives the face images headless.
// Kernels, in host call order (one work-item per pixel; row 0 is the bottom row, as in a GL texture):
//   RenderFaces       shapes, world, face_basis, face_lens, eye_cg -> face_images (faces, H, W) uchar4: pixel
//                     centre -> NDC (x, y) -> view direction ((x + P02) / P00, (y + P12) / P11, -1) -> world
//                     direction X R + Y U + F of face k's camera at the eye -> traced colour (section 9.4)
//   RenderEyeDirect   shapes, world, eye_basis, eye_lens, eye_cg -> eye_image (H, W) uchar4: a pinhole camera at
//                     the eye, what a perfect projection room shows its viewer
//   CompositeEyeView  face_images, room faces, eye -> eye_image: the same pinhole camera standing in the room; each
//                     ray leaves the room through one face and samples that face's image bilinearly (clamped to
//                     the edge), the way a viewer sees the projected walls; black where no face is (the ceiling
//                     of the 5-face room)
// Build defines: MARCH_STEPS (sphere-tracing steps per ray), SURFACE_EPSILON (hit distance), MAX_DISTANCE (rays
// end there and show the sky); all CG units, from the host module's constants of the same names.
// Atomics: none. Races: none: every work-item writes its own pixel and reads only inputs.
// Differences from the book: the world (the book uses a third-party city asset); the ceiling as a 6th face (the
// book notes it is possible); colours are traced, not rasterised, so there is no near/far clipping here.

typedef struct {
    float4 center;  // xyz: centre, CG units; w: SHAPE_SPHERE or SHAPE_BOX
    float4 size;    // xyz: box half extents; x: sphere radius
    float4 color;   // rgb albedo
} Shape;

typedef struct {
    float4 sun_direction;  // xyz: the direction the sunlight travels (unit)
    float4 sun_color;
    float4 ambient;
    float4 sky_horizon;
    float4 sky_zenith;
    float4 ground_dark;   // checker colours of the ground
    float4 ground_light;
    float4 ground;        // x: height of the ground plane, y: checker square size, z: fog distance (CG units)
} World;

#define SHAPE_SPHERE 0.0f
#define SHAPE_BOX 1.0f

inline float shape_distance(const __global Shape* shape, float3 p) {
    const float3 q = p - shape->center.xyz;
    if (shape->center.w == SHAPE_SPHERE) return length(q) - shape->size.x;
    const float3 d = fabs(q) - shape->size.xyz;
    return length(fmax(d, 0.0f)) + fmin(fmax(d.x, fmax(d.y, d.z)), 0.0f);
}

inline float3 shape_normal(const __global Shape* shape, float3 p) {
    const float3 q = p - shape->center.xyz;
    if (shape->center.w == SHAPE_SPHERE) return normalize(q);
    const float3 r = fabs(q / shape->size.xyz);  // the face a point lies on has the largest |q| / half extent
    if (r.x >= r.y && r.x >= r.z) return (float3)(sign(q.x), 0.0f, 0.0f);
    if (r.y >= r.z) return (float3)(0.0f, sign(q.y), 0.0f);
    return (float3)(0.0f, 0.0f, sign(q.z));
}

inline float3 sky(const __global World* world, float3 dir) {
    return mix(world->sky_horizon.xyz, world->sky_zenith.xyz, sqrt(clamp(dir.y, 0.0f, 1.0f)));
}

// The colour seen from `origin` along `direction` (any length): sphere tracing of the shapes up to the ground plane,
// which is hit analytically; lit by the sun and the ambient, fogged towards the sky with distance.
inline float3 trace(const __global Shape* shapes, int shape_count, const __global World* world, float3 origin,
                    float3 direction) {
    const float3 dir = normalize(direction);
    const float ground_y = world->ground.x;
    const float t_ground = (dir.y < 0.0f && origin.y > ground_y) ? (ground_y - origin.y) / dir.y : INFINITY;
    const float t_limit = fmin(t_ground, MAX_DISTANCE);
    float t = 0.0f;
    int hit = -1;
    for (int step = 0; step < MARCH_STEPS && t < t_limit; ++step) {
        const float3 p = origin + t * dir;
        float nearest = INFINITY;
        int nearest_shape = -1;
        for (int s = 0; s < shape_count; ++s) {
            const float d = shape_distance(&shapes[s], p);
            if (d < nearest) {
                nearest = d;
                nearest_shape = s;
            }
        }
        if (nearest < SURFACE_EPSILON) {
            hit = nearest_shape;
            break;
        }
        t += nearest;
    }
    float3 albedo, normal;
    if (hit >= 0) {
        normal = shape_normal(&shapes[hit], origin + t * dir);
        albedo = shapes[hit].color.xyz;
    } else if (t_ground < MAX_DISTANCE) {
        t = t_ground;
        const float3 p = origin + t * dir;
        // a soft checker (smooth, so that resampled face images stay close to the direct view)
        const float k = M_PI_F / world->ground.y;
        normal = (float3)(0.0f, 1.0f, 0.0f);
        albedo = mix(world->ground_dark.xyz, world->ground_light.xyz, 0.5f + 0.5f * sin(k * p.x) * sin(k * p.z));
    } else {
        return sky(world, dir);
    }
    const float diffuse = fmax(dot(normal, -world->sun_direction.xyz), 0.0f);
    const float3 lit = albedo * (world->ambient.xyz + world->sun_color.xyz * diffuse);
    return mix(lit, sky(world, dir), 1.0f - exp(-t / world->ground.z));
}

// Pixel (i, j) of a width x height image through a camera with basis (R, U, F) = basis[0..8] and lens
// (P00, P02, P11, P12): the world direction of the pixel centre (the inverse of section 9.3's Proj on z = -1).
inline float3 pixel_direction(int i, int j, int width, int height, const __global float* basis, float4 lens) {
    const float x = 2.0f * (i + 0.5f) / width - 1.0f;
    const float y = 2.0f * (j + 0.5f) / height - 1.0f;
    const float vx = (x + lens.y) / lens.x;
    const float vy = (y + lens.w) / lens.z;
    const float3 right = vload3(0, basis), up = vload3(1, basis), forward = vload3(2, basis);
    return vx * right + vy * up + forward;
}

inline uchar4 rgba8(float3 color) {
    return (uchar4)(convert_uchar3_sat_rte(color * 255.0f), 255);
}

__kernel void RenderFaces(__global uchar4* face_images, const __global Shape* shapes, int shape_count,
                          const __global World* world, const __global float* face_basis,
                          const __global float4* face_lens, float4 eye_cg, int width, int height) {
    const int i = get_global_id(0), j = get_global_id(1), k = get_global_id(2);
    if (i >= width || j >= height) return;
    const float3 direction = pixel_direction(i, j, width, height, face_basis + 9 * k, face_lens[k]);
    face_images[((size_t)k * height + j) * width + i] = rgba8(trace(shapes, shape_count, world, eye_cg.xyz, direction));
}

__kernel void RenderEyeDirect(__global uchar4* eye_image, const __global Shape* shapes, int shape_count,
                              const __global World* world, const __global float* eye_basis, float4 eye_lens,
                              float4 eye_cg, int width, int height) {
    const int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    const float3 direction = pixel_direction(i, j, width, height, eye_basis, eye_lens);
    eye_image[(size_t)j * width + i] = rgba8(trace(shapes, shape_count, world, eye_cg.xyz, direction));
}

// Bilinear sample of image k (row 0 at the bottom) at texture coordinates (u, v) in [0, 1], clamped to the edge.
inline float4 sample_face(const __global uchar4* images, int k, int width, int height, float u, float v) {
    const float x = clamp(u * width - 0.5f, 0.0f, width - 1.0f);
    const float y = clamp(v * height - 0.5f, 0.0f, height - 1.0f);
    const int x0 = (int)floor(x), y0 = (int)floor(y);
    const int x1 = min(x0 + 1, width - 1), y1 = min(y0 + 1, height - 1);
    const float fx = x - x0, fy = y - y0;
    const __global uchar4* image = images + (size_t)k * width * height;
    const float4 bottom = mix(convert_float4(image[y0 * width + x0]), convert_float4(image[y0 * width + x1]), fx);
    const float4 top = mix(convert_float4(image[y1 * width + x0]), convert_float4(image[y1 * width + x1]), fx);
    return mix(bottom, top, fy);
}

__kernel void CompositeEyeView(__global uchar4* eye_image, const __global uchar4* face_images, int faces,
                               int face_width, int face_height, const __global float* room_basis,
                               const __global float* room_center, const __global float* room_size, float4 eye,
                               const __global float* eye_basis, float4 eye_lens, int width, int height) {
    const int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    const float3 direction = pixel_direction(i, j, width, height, eye_basis, eye_lens);
    // the ray leaves the box through the nearest of the six planes it heads towards (the eye is inside)
    float t_exit = INFINITY;
    int exit_face = 0;
    for (int k = 0; k < 6; ++k) {
        const float3 forward = vload3(3 * k + 2, room_basis);
        const float towards = dot(direction, forward);
        if (towards <= 0.0f) continue;
        const float t = dot(vload3(k, room_center) - eye.xyz, forward) / towards;
        if (t < t_exit) {
            t_exit = t;
            exit_face = k;
        }
    }
    uchar4 color = (uchar4)(0, 0, 0, 255);
    if (exit_face < faces) {
        const int k = exit_face;
        const float3 q = eye.xyz + t_exit * direction - vload3(k, room_center);
        const float u = dot(q, vload3(3 * k, room_basis)) / room_size[2 * k] + 0.5f;  // along the face's right
        const float v = dot(q, vload3(3 * k + 1, room_basis)) / room_size[2 * k + 1] + 0.5f;  // along its up
        color = convert_uchar4_sat_rte(sample_face(face_images, k, face_width, face_height, u, v));
    }
    eye_image[(size_t)j * width + i] = color;
}
