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
#ifdef SHIRLEY_TUCHMAN
layout(triangle_strip, max_vertices = 8) out;
#else
layout(triangle_strip, max_vertices = 8) out;
#endif

#include "mesh_fetch.glsl"
#ifdef SHIRLEY_TUCHMAN
#include "transfer_segment.glsl"
#endif
#include "pt_silhouette.glsl"

#ifdef SHIRLEY_TUCHMAN
noperspective out vec4 g_st;  // colour, optical depth (pt_st.frag)
flat out float g_tau_max;     // the thick vertex's optical depth: the most the interpolation may give
#endif

flat in uint v_entry[];
flat out uint g_cell;

const uint COVER_ALL = 0x80000000u;

void emit(vec2 pixel) {
    g_cell = v_entry[0] & ~COVER_ALL;
    gl_Position = vec4(pixel / u_image_size * 2.0 - 1.0, 0.0, 1.0);
    EmitVertex();
}

#ifdef SHIRLEY_TUCHMAN
// Shirley and Tuchman's variant: the footprint as 3 or 4 triangles around the thick vertex (class 1:
// the vertex projecting inside; class 2: where the diagonals cross), its colour and optical depth
// from the exact integral along its own ray (clipped against the cell's planes, as pt.frag does per
// fragment), the silhouette's vertices of zero thickness with the transfer function's colour at
// their scalar; pt_st.frag turns the interpolated pair into opacity.  No margin: neighbouring
// footprints share their edges, and the rasterizer's fill rule gives a pixel to one of them.
// The colours of the four vertices, each looked up once; a silhouette corner takes its vertex's.
struct Corners { vec2 q0, q1, q2; vec3 c0, c1, c2, c3; };

float cell_tau_max;  // the thick vertex's optical depth, given with every vertex (outputs are undefined after
                     // EmitVertex)

void emit_st(vec2 pixel, vec4 st) {
    g_st = st;
    g_tau_max = cell_tau_max;
    emit(pixel);
}

void corner(Corners k, vec2 h) {  // a silhouette corner: zero thickness
    emit_st(h, vec4(h == k.q0 ? k.c0 : (h == k.q1 ? k.c1 : (h == k.q2 ? k.c2 : k.c3)), 0.0));
}

// Two triangles of the fan around the thick vertex as one strip, thick a b and thick b c, both
// counter-clockwise (a strip's odd triangle is drawn as its second, first and third: thick b c).
void fan_pair(Corners k, vec2 thick, vec4 at_thick, vec2 a, vec2 b, vec2 c) {
    corner(k, a);
    corner(k, b);
    emit_st(thick, at_thick);
    corner(k, c);
    EndPrimitive();
}

void shirley_tuchman(Cell v, vec2 h0, vec2 h1, vec2 h2, vec2 h3, bool quad, int inner) {
    uint cell = v_entry[0] & ~COVER_ALL;
    vec4 linear = cell_texel(cell, 5u);
    vec2 thick;
    vec4 at_thick = thick_vertex(v, cell, linear, h0, h1, h2, h3, quad, inner, thick);
    cell_tau_max = at_thick.a;
    Corners k = Corners(v.q0, v.q1, v.q2, vertex_colour(v.p0, linear), vertex_colour(v.p1, linear),
                        vertex_colour(v.p2, linear), vertex_colour(v.p3, linear));
    fan_pair(k, thick, at_thick, h0, h1, h2);
    if (quad) {
        fan_pair(k, thick, at_thick, h2, h3, h0);
    } else {  // the third triangle: thick h2 h0
        corner(k, h2);
        corner(k, h0);
        emit_st(thick, at_thick);
        EndPrimitive();
    }
}
#endif

void main() {
    if ((v_entry[0] & COVER_ALL) != 0u) {
        emit(vec2(-1.0)); emit(vec2(u_image_size.x + 1.0, -1.0));
        emit(vec2(-1.0, u_image_size.y + 1.0)); emit(u_image_size + 1.0);
        EndPrimitive();
        return;
    }
    Cell v = projected_cell(v_entry[0]);
    vec2 h0, h1, h2, h3;
    int inner;
    bool quad;
    if (!silhouette(v, h0, h1, h2, h3, inner, quad)) {  // flat (a cell seen edge on): its bounding box
#ifdef SHIRLEY_TUCHMAN
        return;  // no area: nothing of it is interpolated
#endif
        vec2 lo = min(min(v.q0, v.q1), min(v.q2, v.q3)) - u_margin;
        vec2 hi = max(max(v.q0, v.q1), max(v.q2, v.q3)) + u_margin;
        emit(lo); emit(vec2(hi.x, lo.y)); emit(vec2(lo.x, hi.y)); emit(hi);
        EndPrimitive();
        return;
    }
#ifdef SHIRLEY_TUCHMAN
    shirley_tuchman(v, h0, h1, h2, h3, quad, inner);
    return;
#endif
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
