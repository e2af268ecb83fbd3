#version 430 core
// The sample's "Unlit/CanvasObjectVisualizer": the canvas at the paint layout uv, the guide overlaid per channel
// by overlay or screen, whichever differs more from the canvas, mixed in by the guide's alpha. `shade` > 0 adds a
// headlight term so that unpainted shapes read (0 = the sample's unlit look).
in vec3 v_normal;
in vec3 v_position;
in vec2 v_uv;

uniform sampler2D canvas;
uniform sampler2D guide;
uniform bool show_guide;
uniform float shade;
uniform vec3 eye;

out vec4 f_color;

void main() {
    vec3 col = texture(canvas, v_uv).rgb;
    if (show_guide) {
        vec4 g = texture(guide, v_uv);
        vec3 overlay = mix(2.0 * col * g.rgb, 1.0 - 2.0 * (1.0 - col) * (1.0 - g.rgb), step(0.5, g.rgb));
        vec3 screen = 1.0 - (1.0 - col) * (1.0 - g.rgb);
        vec3 blended = mix(overlay, screen, vec3(lessThan(abs(col - overlay), abs(col - screen))));
        col = mix(col, blended, g.a);
    }
    float facing = abs(dot(normalize(v_normal), normalize(eye - v_position)));
    f_color = vec4(col * mix(1.0, 0.55 + 0.45 * facing, shade), 1.0);
}
