#version 430 core
// Sample.shader (vol.1 ch.4): col = the camera's white * (1 - 5 * density), saturated: black ink on white.
// Other display modes (not in the book): density grey, velocity, |divergence| heat map.
uniform sampler2D field;   // what the display mode shows, one texel per cell, row 0 at the bottom (DrawTexture's half
                           // floats): density (ink, density), (u, v) (velocity) or du/dx + dv/dy (divergence)
uniform int display_mode;  // 0 ink, 1 density, 2 velocity, 3 |divergence|
uniform bool ink_effect;   // the original's RenderEffect on/off: off shows the camera's plain white
uniform float ink_gain;    // Params.ink_gain (book: 5)
uniform float velocity_scale;    // 1 / the largest |u| or |v| on screen
uniform float divergence_scale;  // 1 / the largest |div| on screen
in vec2 v_uv;
out vec4 f_color;

const vec3 BACKGROUND = vec3(1.0);  // the sample camera's solid white clear colour

void main() {
    if (display_mode == 0) {
        float density = texture(field, v_uv).r;
        f_color = vec4(ink_effect ? clamp(BACKGROUND * (1.0 - ink_gain * density), 0.0, 1.0) : BACKGROUND, 1.0);
    } else if (display_mode == 1) {
        f_color = vec4(vec3(clamp(texture(field, v_uv).r * ink_gain, 0.0, 1.0)), 1.0);
    } else if (display_mode == 2) {
        f_color = vec4(clamp(0.5 + 0.5 * texture(field, v_uv).rg * velocity_scale, 0.0, 1.0), 0.5, 1.0);
    } else {  // one flat colour a cell, as the divergence is a value per cell
        ivec2 size = textureSize(field, 0);
        ivec2 cell = clamp(ivec2(v_uv * vec2(size)), ivec2(0), size - 1);
        float t = clamp(abs(texelFetch(field, cell, 0).r) * divergence_scale, 0.0, 1.0);
        f_color = vec4(t, t * t, 0.2 * (1.0 - t), 1.0);  // black-red-yellow heat
    }
}
