#version 430 core
// SimpleGeometryShader (vol.1 ch.6), geometry part geom(): every triangle becomes a triangular pyramid, the base plus
// three sides meeting at the centroid pushed along object -Z by height (fig. 6.3); four separate triangles.
layout(triangles) in;
layout(triangle_strip, max_vertices = 12) out;  // [maxvertexcount(12)] = 4 triangles x 3 vertices

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;
uniform float height;     // _Height
uniform vec4 top_color;     // _TopColor
uniform vec4 bottom_color;  // _BottomColor

in vec3 v_position[];

out vec4 g_color;
out vec3 g_world;

void emit(vec3 p, vec4 color) {
    vec4 world = m_model * vec4(p, 1.0);
    g_world = world.xyz;
    g_color = color;
    gl_Position = m_proj * m_view * world;  // UnityObjectToClipPos
    EmitVertex();
}

void main() {
    vec3 p0 = v_position[0], p1 = v_position[1], p2 = v_position[2];
    vec3 c = vec3(0.0, 0.0, -height) + (p0 + p1 + p2) * 0.33333;  // the book's literal

    emit(p0, bottom_color);  // bottom
    emit(p1, bottom_color);
    emit(p2, bottom_color);
    EndPrimitive();  // RestartStrip
    emit(p0, bottom_color);  // sides
    emit(p1, bottom_color);
    emit(c, top_color);
    EndPrimitive();
    emit(p1, bottom_color);
    emit(p2, bottom_color);
    emit(c, top_color);
    EndPrimitive();
    emit(p2, bottom_color);
    emit(p0, bottom_color);
    emit(c, top_color);
    EndPrimitive();
}
