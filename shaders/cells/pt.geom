#version 430
// Projected tetrahedra (Shirley and Tuchman 1990): the footprint of each cell.
//
// The four vertices are projected; their convex hull is the silhouette, Shirley-Tuchman's class 1
// (a triangle: one vertex projects inside the other three) or class 2 (a quadrilateral: the two
// diagonals are the pairs each separating the other two).  Instead of interpolating the thick
// vertex's thickness across the footprint (exact only in orthographic projection), every fragment
// clips its own ray against the cell's planes (pt.frag), so the footprint only says which pixels
// to visit, each once.  The rasterizer snaps vertices to a sub-pixel grid, so a pixel centre just
// inside the silhouette could fall outside it, and with it a piece of the cell (all of a thin cell
// seen edge on): the silhouette is grown by u_margin pixels, every edge moved out by the margin
// and the corners bevelled (a mitre would reach far out of a sharp corner, and a capped one would
// move the edges of a sliver by less than the margin).  A fragment outside the cell finds no piece
// and is discarded.  Cells seen edge on (all four on a line) draw their grown bounding box; a cell
// reaching behind the eye's plane (COVER_ALL) covers the whole image.
layout(points) in;
layout(triangle_strip, max_vertices = 8) out;

#include "cells/mesh_fetch.glsl"

uniform mat4 u_view_projection;  // centre-relative world -> clip
uniform vec2 u_image_size;
uniform float u_margin;          // pixels

flat in uint v_entry[];
flat out uint g_cell;

const uint COVER_ALL = 0x80000000u;

void emit(vec2 pixel) {
    g_cell = v_entry[0] & ~COVER_ALL;
    gl_Position = vec4(pixel / u_image_size * 2.0 - 1.0, 0.0, 1.0);
    EmitVertex();
}

float orient(vec2 a, vec2 b, vec2 c) { return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x); }

vec2 outward(vec2 a, vec2 b) {  // the outward unit normal of edge a -> b of a counter-clockwise polygon
    vec2 e = vec2(b.y - a.y, a.x - b.x);
    float len = length(e);
    return len > 0.0 ? e / len : vec2(0.0);
}

bool inside(vec2 p, vec2 a, vec2 b, vec2 c) {  // p in the triangle abc, either orientation
    float u = orient(a, b, p), v = orient(b, c, p), w = orient(c, a, p);
    return (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
}

void main() {
    if ((v_entry[0] & COVER_ALL) != 0u) {
        emit(vec2(-1.0)); emit(vec2(u_image_size.x + 1.0, -1.0));
        emit(vec2(-1.0, u_image_size.y + 1.0)); emit(u_image_size + 1.0);
        EndPrimitive();
        return;
    }
    uvec4 ids = mesh_cell(v_entry[0]);
    vec2 q0, q1, q2, q3;
    {
        vec4 c0 = u_view_projection * vec4(mesh_point(ids.x).xyz, 1.0);
        vec4 c1 = u_view_projection * vec4(mesh_point(ids.y).xyz, 1.0);
        vec4 c2 = u_view_projection * vec4(mesh_point(ids.z).xyz, 1.0);
        vec4 c3 = u_view_projection * vec4(mesh_point(ids.w).xyz, 1.0);
        q0 = (c0.xy / c0.w * 0.5 + 0.5) * u_image_size;  // pixels
        q1 = (c1.xy / c1.w * 0.5 + 0.5) * u_image_size;
        q2 = (c2.xy / c2.w * 0.5 + 0.5) * u_image_size;
        q3 = (c3.xy / c3.w * 0.5 + 0.5) * u_image_size;
    }
    // the silhouette, counter-clockwise: hull[0 .. n - 1]
    vec2 hull[4];
    int n = 4;
    if (inside(q3, q0, q1, q2)) { hull[0] = q0; hull[1] = q1; hull[2] = q2; n = 3; }
    else if (inside(q2, q0, q1, q3)) { hull[0] = q0; hull[1] = q1; hull[2] = q3; n = 3; }
    else if (inside(q1, q0, q2, q3)) { hull[0] = q0; hull[1] = q2; hull[2] = q3; n = 3; }
    else if (inside(q0, q1, q2, q3)) { hull[0] = q1; hull[1] = q2; hull[2] = q3; n = 3; }
    else if (orient(q0, q1, q2) * orient(q0, q1, q3) < 0.0) { hull[0] = q0; hull[1] = q2; hull[2] = q1; hull[3] = q3; }
    else if (orient(q0, q2, q1) * orient(q0, q2, q3) < 0.0) { hull[0] = q0; hull[1] = q1; hull[2] = q2; hull[3] = q3; }
    else { hull[0] = q0; hull[1] = q1; hull[2] = q3; hull[3] = q2; }
    float area = orient(hull[0], hull[1], hull[2]) + (n == 4 ? orient(hull[0], hull[2], hull[3]) : 0.0);
    if (!(abs(area) > 0.0)) {  // flat: all four on a line (a cell seen edge on): its bounding box
        vec2 lo = min(min(q0, q1), min(q2, q3)) - u_margin;
        vec2 hi = max(max(q0, q1), max(q2, q3)) + u_margin;
        emit(lo); emit(vec2(hi.x, lo.y)); emit(vec2(lo.x, hi.y)); emit(hi);
        EndPrimitive();
        return;
    }
    if (area < 0.0) {  // clockwise: reverse
        vec2 t = hull[1]; hull[1] = hull[n - 1]; hull[n - 1] = t;
    }
    // bevelled: each corner becomes two points, one on each of its edges moved out
    vec2 grown[8];
    for (int i = 0; i < n; ++i) {
        vec2 prev = hull[(i + n - 1) % n], cur = hull[i], next = hull[(i + 1) % n];
        grown[2 * i] = cur + u_margin * outward(prev, cur);
        grown[2 * i + 1] = cur + u_margin * outward(cur, next);
    }
    // a convex polygon as a strip: 0, 1, m-1, 2, m-2, ...
    int m = 2 * n;
    emit(grown[0]);
    emit(grown[1]);
    for (int i = 2, j = m - 1; i <= j; ++i, --j) {
        emit(grown[j]);
        if (i < j) emit(grown[i]);
    }
    EndPrimitive();
}
