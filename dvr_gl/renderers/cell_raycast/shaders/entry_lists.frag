#version 430
// Per-pixel linked lists of the boundary faces where the pixel's ray enters the mesh (an A-buffer):
// each fragment of a face the ray crosses inwards appends (cell, t, next) to a shared node buffer
// and makes itself the head of its pixel's list.  Nodes past u_capacity are counted, not stored:
// the host sees the overflow in the counter and draws again with room for them.
#include "common/camera_ray.glsl"

flat in uint g_cell;
flat in vec3 g_normal;  // out of the cell
flat in vec3 g_corner0, g_corner1, g_corner2;

layout(std430, binding = 0) writeonly buffer Nodes { uvec4 nodes[]; };  // (cell, t's bits, next node + 1, 0)
layout(std430, binding = 1) buffer Count { uint node_count; };
layout(r32ui, binding = 0) uniform coherent uimage2D u_heads;  // first node + 1 per pixel, 0: none
uniform uint u_capacity;

// How far outside the face (in barycentric coordinates) a crossing still counts: float32 rounding
// of the hit; a ray passing this close enters by the face's edge, and the walk finds its way.
const float EDGE_SLACK = 1e-4;

void main() {
    vec3 o, d;
    camera_ray(o, d);
    float nd = dot(g_normal, d);
    if (nd >= 0.0) discard;  // a face the ray leaves by (or lies in)
    float t = dot(g_corner0 - o, g_normal) / nd;
    // the crossing's barycentric coordinates: the grown footprint also covers rays beside the face
    vec3 p = o + t * d;
    vec3 n = cross(g_corner1 - g_corner0, g_corner2 - g_corner0);
    float inv = 1.0 / dot(n, n);
    float w0 = dot(cross(g_corner2 - g_corner1, p - g_corner1), n) * inv;
    float w1 = dot(cross(g_corner0 - g_corner2, p - g_corner2), n) * inv;
    float w2 = 1.0 - w0 - w1;
    if (min(min(w0, w1), w2) < -EDGE_SLACK) discard;
    uint i = atomicAdd(node_count, 1u);
    if (i >= u_capacity) discard;  // counted: the host sees the overflow
    uint next = imageAtomicExchange(u_heads, ivec2(gl_FragCoord.xy), i + 1u);
    nodes[i] = uvec4(g_cell, floatBitsToUint(t), next, 0u);
}
