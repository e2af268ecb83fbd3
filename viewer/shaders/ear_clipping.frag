#version 430 core
// Ear clipping fill: a procedural stand-in for the sample's photo texture, a UV gradient under a checkerboard of
// `checker_cells` cells per unit of uv, so the planar UV mapping shows.
in vec2 v_uv;

uniform float checker_cells;
uniform float opacity;

out vec4 f_color;

void main() {
    vec2 cell = floor(v_uv * checker_cells);
    float checker = mod(cell.x + cell.y, 2.0) < 1.0 ? 1.0 : 0.78;
    vec3 gradient = vec3(0.25 + 0.7 * v_uv.x, 0.35 + 0.55 * v_uv.y, 0.85 - 0.4 * v_uv.x);
    f_color = vec4(gradient * checker, opacity);
}
