#version 430 core
// Particle.shader (vol.1 ch.5), vertex part: one point per fluid particle (book: DrawProcedural(Points) reading
// _ParticlesBuffer[SV_VertexID]); here the FluidParticle records are the vertex buffer (stride 16).
in vec2 in_position;
in vec2 in_velocity;
in float in_value;  // the density or the pressure, whichever colour_mode shows (stale otherwise: unused)

uniform int color_mode;     // 0 water, 1 speed, 2 density, 3 pressure
uniform float color_scale;  // value drawn at the top of the ramp

out float v_value;  // the coloured quantity in [0, 1] (unused in water mode)

void main() {
    float value = color_mode == 1 ? length(in_velocity) : in_value;
    v_value = clamp(value / max(color_scale, 1e-12), 0.0, 1.0);
    gl_Position = vec4(in_position, 0.0, 1.0);  // world position; the geometry shader projects
}
