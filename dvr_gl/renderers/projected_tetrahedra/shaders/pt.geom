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
// (see main: mitres and bevels).  A fragment outside the cell finds no piece and is discarded.  Cells seen edge on (all four on a line) draw their grown bounding box; a cell
// reaching behind the eye's plane (COVER_ALL) covers the whole image.
layout(points) in;
layout(triangle_strip, max_vertices = 8) out;

#include "mesh_fetch.glsl"
#include "grow.glsl"

uniform mat4 u_view_projection;  // centre-relative world -> clip
uniform vec2 u_image_size;

flat in uint v_entry[];
flat out uint g_cell;

const uint COVER_ALL = 0x80000000u;

void emit(vec2 pixel) {
    g_cell = v_entry[0] & ~COVER_ALL;
    gl_Position = vec4(pixel / u_image_size * 2.0 - 1.0, 0.0, 1.0);
    EmitVertex();
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
    // The silhouette, counter-clockwise: h0 h1 h2 (h3).  Named vectors, not a dynamically indexed
    // array: llvmpipe runs several primitives per SIMD call, and a local array written at computed
    // indices under divergent branches came out wrong (corners repeated: pixels covered three times).
    vec2 h0 = q0, h1 = q1, h2 = q2, h3 = q3;
    bool quad = true;
    if (inside(q3, q0, q1, q2)) { quad = false; }
    else if (inside(q2, q0, q1, q3)) { h2 = q3; quad = false; }
    else if (inside(q1, q0, q2, q3)) { h1 = q2; h2 = q3; quad = false; }
    else if (inside(q0, q1, q2, q3)) { h0 = q1; h1 = q2; h2 = q3; quad = false; }
    else if (orient(q0, q1, q2) * orient(q0, q1, q3) < 0.0) { h1 = q2; h2 = q1; }  // diagonal q0 q1
    else if (orient(q0, q2, q1) * orient(q0, q2, q3) >= 0.0) { h2 = q3; h3 = q2; } // diagonal q0 q3
    if (!quad) h3 = h2;
    float area = orient(h0, h1, h2) + (quad ? orient(h0, h2, h3) : 0.0);
    if (!(abs(area) > 0.0)) {  // flat: all four on a line (a cell seen edge on): its bounding box
        vec2 lo = min(min(q0, q1), min(q2, q3)) - u_margin;
        vec2 hi = max(max(q0, q1), max(q2, q3)) + u_margin;
        emit(lo); emit(vec2(hi.x, lo.y)); emit(vec2(lo.x, hi.y)); emit(hi);
        EndPrimitive();
        return;
    }
    if (area < 0.0) {  // clockwise: reverse
        vec2 t = h1;
        h1 = quad ? h3 : h2;
        if (quad) h3 = t; else { h2 = t; h3 = t; }
    }
    // Grown: every edge moved out by the margin.  A corner of 90 degrees or more takes its mitre (at
    // most 1.42 margins out), given twice; a sharper one is bevelled, one point on each moved edge
    // (the mitre would reach far out of a sliver's tips).  Two bevel points at a nearly straight
    // corner would be a hair apart, and the sliver triangles between them and the far side could
    // turn over in the rasterizer's fixed point and cover a pixel again (seen: three times).
    // Edge k runs from corner k to the next; the polygon goes out as a strip zig-zagging from both
    // ends, all its triangles facing the eye (back faces are culled: a triangle turned over by
    // rounding draws nothing).
    vec2 n0 = outward(h0, h1), n1 = outward(h1, h2), n2 = outward(h2, quad ? h3 : h0), n3 = outward(h3, h0);
    vec2 nl = quad ? n3 : n2;  // the edge into corner 0
    vec2 a0, b0, a1, b1, a2, b2;
    grow(h0, nl, n0, a0, b0);
    grow(h1, n0, n1, a1, b1);
    grow(h2, n1, n2, a2, b2);
    if (quad) {
        vec2 a3, b3;
        grow(h3, n2, n3, a3, b3);
        emit(a0); emit(b0); emit(b3); emit(a1); emit(a3); emit(b1); emit(b2); emit(a2);
    } else {
        emit(a0); emit(b0); emit(b2); emit(a1); emit(a2); emit(b1);
    }
    EndPrimitive();
}
