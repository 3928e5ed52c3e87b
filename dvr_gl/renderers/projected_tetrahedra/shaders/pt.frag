#version 430
// Projected tetrahedra: the fragment's own ray clipped against its cell's four face planes
// (exact in perspective and orthographic, as dvr_gl/fields/mesh_rays.py in float64), the scalar
// linear along the piece inside, and
//   EMISSION: the emission-absorption integral of the exact transfer function along the piece
//     (transfer_segment.glsl): premultiplied (C, 1 - exp(-tau)), composited by the over operator
//     in visibility order;
//   MIP, MINIP: the larger (smaller) end value, blended by max (min);
//   AVERAGE: the integral of the value along the piece, blended by addition;
//   ISOSURFACE: where the piece reaches the iso-value: its depth, for the depth test.
// Projections keep a coverage flag in .g; the host classifies the blended value.  CLIPPING and
// GEOMETRY narrow the piece to the kept region and end it at the nearest surface (kept_part.glsl).
#include "common/camera_ray.glsl"
#include "mesh_fetch.glsl"
#include "kept_part.glsl"

flat in uint g_cell;

uniform float u_iso_value;
uniform float u_depth_scale;  // ISOSURFACE: 1 / the farthest ray parameter (depth in [0, 1])

out vec4 frag;

#ifdef EMISSION
#include "transfer_segment.glsl"
#endif

#include "clip_cell.glsl"

void main() {
    vec3 o, d;
    camera_ray(o, d);
    vec4 plane0 = cell_texel(g_cell, 0u), plane1 = cell_texel(g_cell, 1u), plane2 = cell_texel(g_cell, 2u);
    vec4 plane3 = cell_texel(g_cell, 3u), side = cell_texel(g_cell, 4u), linear = cell_texel(g_cell, 5u);
    float t_in = max(near_distance(d), 0.0);
    float t_out = 3.0e38;
    clip_face(plane0, side.x, o, d, t_in, t_out);
    clip_face(plane1, side.y, o, d, t_in, t_out);
    clip_face(plane2, side.z, o, d, t_in, t_out);
    clip_face(plane3, side.w, o, d, t_in, t_out);
    kept_part(o, d, t_in, t_out);
    if (!(t_out > t_in)) discard;  // the ray misses the cell (the footprint is grown), or its kept part
#ifdef FRAGMENT_COUNT
    frag = vec4(1.0, 0.0, 0.0, 0.0);  // added up: the cells this pixel's fragments found (tests)
    return;
#endif
    float s_front = dot(linear.xyz, o + t_in * d) + linear.w;
    float s_back = dot(linear.xyz, o + t_out * d) + linear.w;
    float len = t_out - t_in;
#if defined(EMISSION)
    frag = transfer_segment(s_front, s_back, len);
#elif defined(MIP)
    frag = vec4(max(s_front, s_back), 1.0, 0.0, 0.0);
#elif defined(MINIP)
    frag = vec4(min(s_front, s_back), -1.0, 0.0, 0.0);
#elif defined(AVERAGE)
    frag = vec4(0.5 * len * (s_front + s_back), 1.0, 0.0, 0.0);
#elif defined(ISOSURFACE)
    if (max(s_front, s_back) < u_iso_value) discard;  // never reaches it
    // the first point with value >= iso from the front: the front itself when it is already there
    float t = s_front >= u_iso_value ? t_in : t_in + len * (u_iso_value - s_front) / (s_back - s_front);
    gl_FragDepth = clamp(t * u_depth_scale, 0.0, 1.0);
    frag = vec4(t, 1.0, 0.0, 0.0);  // the hit and the coverage flag
#endif
}
