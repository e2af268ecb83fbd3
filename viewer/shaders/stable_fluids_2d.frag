#version 430 core
// Sample.shader (vol.1 ch.4): col = the camera's white * (1 - 5 * density), saturated: black ink on white.
// Other display modes (not in the book): density grey, velocity, |divergence| heat map.
uniform sampler2D solver;  // Draw output (u, v, density, 1), one texel per cell, row 0 at the bottom
uniform int display_mode;  // 0 ink, 1 density, 2 velocity, 3 |divergence|
uniform bool ink_effect;   // the original's RenderEffect on/off: off shows the camera's plain white
uniform float ink_gain;    // Params.ink_gain (book: 5)
uniform float velocity_scale;    // 1 / the largest |v| on screen
uniform float divergence_scale;  // 1 / the largest |div| on screen
in vec2 v_uv;
out vec4 f_color;

const vec3 BACKGROUND = vec3(1.0);  // the sample camera's solid white clear colour

// du/dx + dv/dy by central differences over a domain of length 1 (ugpcl.scenes.stable_fluids_2d.central_divergence)
float divergence(ivec2 cell, ivec2 size) {
    float u1 = cell.x + 1 < size.x ? texelFetch(solver, cell + ivec2(1, 0), 0).x : 0.0;
    float u0 = cell.x > 0 ? texelFetch(solver, cell - ivec2(1, 0), 0).x : 0.0;
    float v1 = cell.y + 1 < size.y ? texelFetch(solver, cell + ivec2(0, 1), 0).y : 0.0;
    float v0 = cell.y > 0 ? texelFetch(solver, cell - ivec2(0, 1), 0).y : 0.0;
    return 0.5 * ((u1 - u0) * float(size.x) + (v1 - v0) * float(size.y));
}

void main() {
    vec4 s = texture(solver, v_uv);
    if (display_mode == 0) {
        f_color = vec4(ink_effect ? clamp(BACKGROUND * (1.0 - ink_gain * s.z), 0.0, 1.0) : BACKGROUND, 1.0);
    } else if (display_mode == 1) {
        f_color = vec4(vec3(clamp(s.z * ink_gain, 0.0, 1.0)), 1.0);
    } else if (display_mode == 2) {
        f_color = vec4(clamp(0.5 + 0.5 * s.xy * velocity_scale, 0.0, 1.0), 0.5, 1.0);
    } else {
        ivec2 size = textureSize(solver, 0);
        ivec2 cell = clamp(ivec2(v_uv * vec2(size)), ivec2(0), size - 1);
        float t = clamp(abs(divergence(cell, size)) * divergence_scale, 0.0, 1.0);
        f_color = vec4(t, t * t, 0.2 * (1.0 - t), 1.0);  // black-red-yellow heat
    }
}
