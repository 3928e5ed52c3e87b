#version 430
// One crossing, summed by additive blending.
out vec4 frag;

void main() {
    frag = vec4(1.0, 0.0, 0.0, 0.0);
}
