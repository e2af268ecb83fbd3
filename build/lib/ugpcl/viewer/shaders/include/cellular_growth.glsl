// cellular_growth.glsl: what the cellular growth shaders share (vol.3 ch.4): the simulation's records, read straight
// from the particle and edge buffers (SSBOs, std430: the same 32- and 20-byte layouts as the OpenCL structs), the
// book's nrand and the scenes' colour gradient.

// Particle (clkernels/include/cellular_growth.h): std430 gives vec2 an 8-byte alignment, so the stride is 32.
struct Particle {
    vec2 position;
    vec2 velocity;
    float radius;
    float threshold;
    int links;
    uint alive;
};
layout(std430, binding = 0) readonly buffer Particles { Particle particles[]; };

// Random.cginc's nrand, as the kernels use it.
float nrand(vec2 uv) {
    return fract(sin(dot(uv, vec2(12.9898, 78.233))) * 43758.5453);
}

// The scenes' Gradient (mode Fixed: the colour of the first key at or after u), baked into 128 texels as
// CellularGrowth.CreatePallete does and sampled nearest.
const int GRADIENT_KEYS = 7;
const float GRADIENT_TIME[GRADIENT_KEYS] = float[](0.124, 0.244, 0.327, 0.408, 0.498, 0.779, 0.997);
const vec3 GRADIENT_COLOR[GRADIENT_KEYS] = vec3[](
    vec3(0.635, 0.147, 1.0), vec3(0.265, 1.0, 0.939), vec3(0.988, 0.742, 0.302), vec3(0.950, 0.988, 0.302),
    vec3(1.0, 0.118, 0.611), vec3(0.279, 0.702, 1.0), vec3(0.316, 0.604, 1.0));
const float GRADIENT_TEXELS = 128.0;

vec3 palette(float u) {
    float t = floor(u * GRADIENT_TEXELS) / GRADIENT_TEXELS;  // the texel's own time, x / width
    for (int k = 0; k < GRADIENT_KEYS; k++) {
        if (GRADIENT_TIME[k] >= t) return GRADIENT_COLOR[k];
    }
    return GRADIENT_COLOR[GRADIENT_KEYS - 1];
}

// Colour of particle slot i (book: tex2Dlod(_Gradient, float4(nrand(float2(iid, 0)), 0, 0, 0))).
vec3 particle_color(int i) {
    return palette(nrand(vec2(float(i), 0.0)));
}
