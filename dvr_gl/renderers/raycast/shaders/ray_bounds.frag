#version 330 core
// Ray bounds: (t, -t) where this pixel's ray crosses the face, blended with MIN, so the target
// holds (first entry, -last exit) of the non-empty blocks.  t from the face's plane and the
// pixel's own ray (the ray caster's), not from interpolated positions.
#include "common/camera_ray.glsl"

flat in int v_axis;
flat in float v_plane;
out vec2 frag_bounds;

void main() {
    vec3 o, d;
    camera_ray(o, d);
    if (d[v_axis] == 0.0) discard;  // the ray runs in the face's plane: it crosses another face
    float t = (v_plane - o[v_axis]) / d[v_axis];
    frag_bounds = vec2(t, -t);
}
