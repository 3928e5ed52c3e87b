#version 430
// Projected tetrahedra (Shirley and Tuchman 1990): the footprint of each cell, and its faces'
// planes for the fragment shader.
//
// The four vertices are projected; sorted by angle around their centroid, the one at a reflex
// (or flat) corner is left out: what remains is the silhouette, Shirley-Tuchman's class 1 (a
// triangle: one vertex projects inside the other three) or class 2 (a quadrilateral).  Instead
// of interpolating the thick vertex's thickness across the footprint (exact only in orthographic
// projection), every fragment clips its own ray against the four planes (pt.frag), so the
// footprint need only cover the silhouette once; it may be dilated by u_margin pixels (a fragment
// outside the cell is discarded there; the renderer's MARGIN_PIXELS says why it is 0).  Cells seen
// edge on (all four on a line) draw their bounding box; a cell reaching behind the eye's plane
// covers the whole image.
//
// Face k (opposite vertex k) takes its plane from its vertices in the order of their indices, so
// the two cells sharing a face compute the same plane (mesh_rays.py does the same in float64).
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;

#include "cells/mesh_fetch.glsl"

uniform mat4 u_view_projection;  // centre-relative world -> clip
uniform vec2 u_image_size;
uniform float u_margin;          // pixels
uniform float u_min_w;           // a vertex with clip w below this is (nearly) behind the eye

flat in uint v_cell[];
flat out vec4 g_plane0;
flat out vec4 g_plane1;
flat out vec4 g_plane2;
flat out vec4 g_plane3;
flat out vec4 g_side;
flat out vec4 g_linear;

vec4 planes[4];
vec4 sides;

void face_plane(int k, uvec4 ids, vec3 p[4]) {
    // the three other vertices, sorted by index
    uint a = ids[(k + 1) % 4], b = ids[(k + 2) % 4], c = ids[(k + 3) % 4];
    vec3 pa = p[(k + 1) % 4], pb = p[(k + 2) % 4], pc = p[(k + 3) % 4];
    if (a > b) { uint t = a; a = b; b = t; vec3 q = pa; pa = pb; pb = q; }
    if (b > c) { uint t = b; b = c; c = t; vec3 q = pb; pb = pc; pc = q; }
    if (a > b) { uint t = a; a = b; b = t; vec3 q = pa; pa = pb; pb = q; }
    vec3 n = cross(pb - pa, pc - pa);
    float h = dot(n, pa);
    planes[k] = vec4(n, h);
    sides[k] = dot(n, p[k]) >= h ? 1.0 : -1.0;
}

void emit(vec2 pixel) {
    g_plane0 = planes[0]; g_plane1 = planes[1]; g_plane2 = planes[2]; g_plane3 = planes[3];
    g_side = sides;
    g_linear = mesh_linear(v_cell[0]);
    gl_Position = vec4(pixel / u_image_size * 2.0 - 1.0, 0.0, 1.0);
    EmitVertex();
}

float orient(vec2 a, vec2 b, vec2 c) { return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x); }

vec2 outward(vec2 a, vec2 b) {  // the outward unit normal of edge a -> b of a counter-clockwise polygon
    vec2 e = vec2(b.y - a.y, a.x - b.x);
    float len = length(e);
    return len > 0.0 ? e / len : vec2(0.0);
}

void main() {
    uvec4 ids = mesh_cell(v_cell[0]);
    vec3 p[4];
    vec2 q[4];
    bool behind = false;
    for (int i = 0; i < 4; ++i) {
        p[i] = mesh_point(ids[i]).xyz;
        vec4 clip = u_view_projection * vec4(p[i], 1.0);
        behind = behind || clip.w <= u_min_w;
        q[i] = (clip.xy / clip.w * 0.5 + 0.5) * u_image_size;  // pixels
    }
    for (int k = 0; k < 4; ++k) face_plane(k, ids, p);
    if (behind) {
        emit(vec2(-1.0)); emit(vec2(u_image_size.x + 1.0, -1.0));
        emit(vec2(-1.0, u_image_size.y + 1.0)); emit(u_image_size + 1.0);
        EndPrimitive();
        return;
    }
    // sort by angle around the centroid (counter-clockwise)
    vec2 centre = 0.25 * (q[0] + q[1] + q[2] + q[3]);
    float angle[4];
    int order[4];
    for (int i = 0; i < 4; ++i) { angle[i] = atan(q[i].y - centre.y, q[i].x - centre.x); order[i] = i; }
    for (int i = 1; i < 4; ++i)
        for (int j = i; j > 0 && angle[order[j - 1]] > angle[order[j]]; --j) {
            int t = order[j]; order[j] = order[j - 1]; order[j - 1] = t;
        }
    vec2 hull[4];
    int n = 0;
    for (int i = 0; i < 4; ++i) {
        vec2 prev = q[order[(i + 3) % 4]], cur = q[order[i]], next = q[order[(i + 1) % 4]];
        if (orient(prev, cur, next) > 0.0) hull[n++] = cur;  // a convex corner: on the silhouette
    }
    if (n < 3) {  // flat: all four on a line (a cell seen edge on): its bounding box
        vec2 lo = min(min(q[0], q[1]), min(q[2], q[3])) - u_margin;
        vec2 hi = max(max(q[0], q[1]), max(q[2], q[3])) + u_margin;
        emit(lo); emit(vec2(hi.x, lo.y)); emit(vec2(lo.x, hi.y)); emit(hi);
        EndPrimitive();
        return;
    }
    vec2 grown[4];
    for (int i = 0; i < n; ++i) {
        vec2 prev = hull[(i + n - 1) % n], cur = hull[i], next = hull[(i + 1) % n];
        vec2 n1 = outward(prev, cur), n2 = outward(cur, next);
        grown[i] = cur + u_margin * (n1 + n2) / max(1.0 + dot(n1, n2), 0.1);
    }
    if (n == 3) {
        emit(grown[0]); emit(grown[1]); emit(grown[2]);
    } else {
        emit(grown[0]); emit(grown[1]); emit(grown[3]); emit(grown[2]);
    }
    EndPrimitive();
}
