#version 430 core
// TessellationSurface.shader's shadow caster pass (vol.4 ch.6, `addshadow`): the tessellated, displaced plane seen
// from the light writes depth only; tessellation.frag looks it up to shadow the light.
void main() {}
