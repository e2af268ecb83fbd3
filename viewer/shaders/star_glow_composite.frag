#version 430 core
// StarGlow.shader pass 4 (vol.4 ch.4, STEP 3): the glow onto the source. The book picks the mode with
// multi_compile keywords (_COMPOSITE_TYPE_ADDITIVE ...); here a uniform with the same ids. OpenCL twin: Composite.

uniform sampler2D source;
uniform sampler2D composite;
uniform int composite_type;  // 0 additive, 1 screen, 2 colored additive, 3 colored screen, 4 debug
uniform vec4 color;
in vec2 uv;
out vec4 fragColor;

void main() {
    vec4 main_colour = texture(source, uv);
    vec4 glow = texture(composite, uv);
    if (composite_type == 2 || composite_type == 3) {
        glow.rgb = (glow.r + glow.g + glow.b) * 0.3333 * color.rgb;
    }
    if (composite_type == 1 || composite_type == 3) {
        fragColor = clamp(main_colour + glow - clamp(main_colour * glow, 0.0, 1.0), 0.0, 1.0);
    } else if (composite_type == 0 || composite_type == 2) {
        fragColor = clamp(main_colour + glow, 0.0, 1.0);
    } else {
        fragColor = glow;
    }
}
