#version 330 core
// Bilinear lookup of the premultiplied intermediate image (its border is transparent).
uniform sampler2D u_intermediate;
in vec2 texcoord;
out vec4 frag_color;

void main() {
    frag_color = texture(u_intermediate, texcoord);
}
