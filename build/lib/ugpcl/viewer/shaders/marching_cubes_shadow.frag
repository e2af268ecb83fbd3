#version 430 core
// GPUMarchingCubesRenderStandardMesh.shader (vol.1 ch.7), frag_shadow(): the book returns z / w into Unity's
// shadow map; here the shadow pass renders into a depth texture only, so the fragment writes nothing.
void main() {}
