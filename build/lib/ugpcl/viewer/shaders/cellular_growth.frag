#version 430 core
// CellularGrowth's particle shader, fragment part: the sample's circle texture (a white disc with a thin dark rim,
// transparent outside) times the slot's gradient colour, done here procedurally.
in vec2 v_uv;
in vec3 v_color;
out vec4 f_color;

const float RIM_WIDTH = 0.06;  // of the radius: the texture's 1-2 px rim at 256 px, widened to stay visible
const float RIM_GREY = 0.25;   // brightness of the rim

void main() {
    float d = length(v_uv * 2.0 - 1.0);  // 0 at the centre, 1 on the edge
    float aa = fwidth(d);
    float alpha = 1.0 - smoothstep(1.0 - aa, 1.0, d);
    if (alpha <= 0.0) discard;
    float rim = max(RIM_WIDTH, 1.5 * aa);                     // at least 1.5 pixels wide
    float diameter = 2.0 / max(aa, 1e-6);                     // pixels (aa = one pixel in units of d)
    float grey = mix(1.0, RIM_GREY, smoothstep(6.0, 12.0, diameter));  // discs of a few pixels get no rim
    float shade = mix(1.0, grey, smoothstep(1.0 - rim - aa, 1.0 - rim, d));
    f_color = vec4(v_color * shade, alpha);
}
