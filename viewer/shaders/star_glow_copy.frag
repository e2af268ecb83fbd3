#version 430 core
// StarGlow.shader passes 0 and 3 (vol.4 ch.4): the source as it is, filtered. Pass 3 draws it with
// `Blend OneMinusDstColor One` into the composite target (STEP 2.5); pass 0, which the chapter never uses, is the
// same plain copy: the viewer shows the brightness and composite images with it (keys b, v).

uniform sampler2D source;
in vec2 uv;
out vec4 fragColor;

void main() {
    fragColor = texture(source, uv);
}
