#version 330 core
// GL self-test (dvr info): a float render target must hold values beyond 8 bits
// and the pixel grid must map as expected; see dvr_gl.gl.selftest.
#include "common/pixel.glsl"

out vec4 frag_color;

void main() {
    vec2 centre = pixel_centre();                 // (x + 0.5, y + 0.5), y from the bottom
    frag_color = vec4(centre.x, centre.y, SELFTEST_VALUE, 1.0);
}
