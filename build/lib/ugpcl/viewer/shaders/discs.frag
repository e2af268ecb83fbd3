#version 430 core
// 2D particles: a disc with a soft one-pixel rim inside the instance quad.
in vec2 v_corner;
in vec4 v_color;
out vec4 f_color;

void main() {
    float r = length(v_corner);
    float edge = fwidth(r);
    float alpha = 1.0 - smoothstep(1.0 - edge, 1.0, r);
    if (alpha <= 0.0) discard;
    f_color = vec4(v_color.rgb, v_color.a * alpha);
}
