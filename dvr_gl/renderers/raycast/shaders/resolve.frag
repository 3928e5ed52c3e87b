#version 330 core
// The last step of bricked ray casting: the state the brick passes left, to the image
// (the same as raycast.frag ends with when the volume is in one texture).
#include "common/transfer_function.glsl"
#include "common/optics.glsl"

uniform sampler2D u_state;
uniform float u_unit_distance;
out vec4 frag_color;

void main() {
    vec4 state = texelFetch(u_state, ivec2(gl_FragCoord.xy), 0);
#include "common/resolve.glsl"
}
