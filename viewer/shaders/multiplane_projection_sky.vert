#version 430 core
// The sky behind the CG world of vol.1 ch.9: one triangle over the whole target; each corner is unprojected onto
// the far plane, whose points are affine in screen space (it is parallel to the image plane, off-axis or not).
uniform mat4 m_inverse;  // inverse of m_proj * m_view

out vec3 v_world;
out vec3 v_normal;
out vec3 v_color;

void main() {
    vec2 ndc = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
    vec4 far_point = m_inverse * vec4(ndc, 1.0, 1.0);
    v_world = far_point.xyz / far_point.w;
    v_normal = vec3(0.0, 1.0, 0.0);
    v_color = vec3(0.0);
    gl_Position = vec4(ndc, 1.0, 1.0);
}
