#version 430 core
// Grass.shader (vol.1 ch.6), geometry part geom(): every triangle becomes one blade, a strip of 7 vertices
// (5 triangles) in three sections whose heights come from the height map, whose side (+/- the edge p2 - p0) comes
// from the rotation map and whose joints sway along object +X with the wind map (fig. 6.5). Same arithmetic as
// GrassExpand in clkernels/grass.cl; g_world is there for transform feedback (tests compare the two).
layout(triangles) in;
layout(triangle_strip, max_vertices = 7) out;  // [maxvertexcount(7)]

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float height;          // _Height
uniform float width;           // _Width
uniform float bottom_height;   // _BottomHeight
uniform float middle_height;   // _MiddleHeight
uniform float top_height;      // _TopHeight
uniform float bottom_width;    // _BottomWidth
uniform float middle_width;    // _MiddleWidth
uniform float top_width;       // _TopWidth
uniform float bottom_bend;     // _BottomBend
uniform float middle_bend;     // _MiddleBend
uniform float top_bend;        // _TopBend
uniform float wind_power;      // _WindPower
uniform float time;            // Time.time, seconds
uniform float wind_time_scale; // sin(_Time) keeps only _Time.x = t/20
uniform vec4 top_color;        // _TopColor
uniform vec4 bottom_color;     // _BottomColor

in vec3 v_position[];
in vec3 v_normal[];
in float v_height[];
in float v_rot[];
in float v_wind[];
flat in mat4 v_model[];

out vec4 g_color;
out vec3 g_world;

void main() {
    vec3 p0 = v_position[0], p1 = v_position[1], p2 = v_position[2];
    float h = (v_height[0] + v_height[1] + v_height[2]) / 3.0;
    float r = (v_rot[0] + v_rot[1] + v_rot[2]) / 3.0;
    float w = (v_wind[0] + v_wind[1] + v_wind[2]) / 3.0;

    vec3 center = (p0 + p1 + p2) / 3.0;
    vec3 normal = (v_normal[0] + v_normal[1] + v_normal[2]) / 3.0;  // not normalised (book)

    float bh = h * height * bottom_height, mh = h * height * middle_height, th = h * height * top_height;
    float bw = width * bottom_width, mw = width * middle_width, tw = width * top_width;

    // book: dir = normalize((p2 - p0) * (rot - 0.5)); the map only picks the side, and 0.5 must not give NaN
    vec3 edge = p2 - p0;
    float edge_length = length(edge);
    vec3 dir = (r > 0.5 ? 1.0 : -1.0) * (edge_length > 0.0 ? edge / edge_length : vec3(0.0));

    vec3 v[7];
    v[0] = center - dir * bw;  // bottom
    v[1] = center + dir * bw;
    v[2] = center - dir * mw + normal * bh;  // bottom to middle
    v[3] = center + dir * mw + normal * bh;
    v[4] = v[3] - dir * tw + normal * mh;  // middle to top: both built from v[3] (book)
    v[5] = v[3] + dir * tw + normal * mh;
    v[6] = v[5] + dir * tw + normal * th;  // top

    // Bend: object-space +X times sin(_Time).x
    float sway = wind_power * w * sin(time * wind_time_scale);
    v[2].x += sway * bottom_bend;
    v[3].x += sway * bottom_bend;
    v[4].x += sway * middle_bend;
    v[5].x += sway * middle_bend;
    v[6].x += sway * top_bend;

    // lerp(_BottomColor, _TopColor, 0.33333 / 0.66666) with the book's literals
    vec4 color[4] = vec4[4](bottom_color, mix(bottom_color, top_color, 0.33333), mix(bottom_color, top_color, 0.66666),
                            top_color);
    mat4 model = v_model[0];
    for (int k = 0; k < 7; k++) {  // stream.Append(o[k]); no RestartStrip: one strip
        vec4 world = model * vec4(v[k], 1.0);
        g_world = world.xyz;
        g_color = color[k / 2];
        gl_Position = m_proj * m_view * world;  // UnityObjectToClipPos
        EmitVertex();
    }
    EndPrimitive();
}
