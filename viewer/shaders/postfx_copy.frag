#version 430 core
// Copy pass (viewer/postfx.py): the source texel under each pixel, fetched without filtering, so a same-sized
// float target receives its input bit for bit.

uniform sampler2D source;
out vec4 fragColor;

void main() {
    fragColor = texelFetch(source, ivec2(gl_FragCoord.xy), 0);
}
