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
#include "grow.glsl"

uniform mat4 u_view_projection;  // centre-relative world -> clip
uniform vec2 u_image_size;
#ifdef SHIRLEY_TUCHMAN
#include "transfer_segment.glsl"
uniform vec3 u_eye;      // relative to the mesh's centre, as the points
uniform vec3 u_forward;
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

bool inside(vec2 p, vec2 a, vec2 b, vec2 c) {  // p in the triangle abc, either orientation
    float u = orient(a, b, p), v = orient(b, c, p), w = orient(c, a, p);
    return (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
}

#ifdef SHIRLEY_TUCHMAN
// Shirley and Tuchman's variant: the footprint as 3 or 4 triangles around the thick vertex (class 1:
// the vertex projecting inside; class 2: where the diagonals cross), its colour and optical depth
// from the exact integral along its own ray (clipped against the cell's planes, as pt.frag does per
// fragment), the silhouette's vertices of zero thickness with the transfer function's colour at
// their scalar; pt_st.frag turns the interpolated pair into opacity.  No margin: neighbouring
// footprints share their edges, and the rasterizer's fill rule gives a pixel to one of them.
// The cell's vertices (centre-relative), fetched once, and their projections (pixels).
struct Cell { vec3 p0, p1, p2, p3; vec2 q0, q1, q2, q3; };

vec3 point_of(Cell v, vec2 h) {  // the vertex a silhouette corner is
    return h == v.q0 ? v.p0 : (h == v.q1 ? v.p1 : (h == v.q2 ? v.p2 : v.p3));
}

vec3 vertex_colour(vec3 p, vec4 linear) {  // the transfer function's colour at a vertex's scalar
    float s = dot(linear.xyz, p) + linear.w;
    return tf_in(tf_interval_at(tf_interval(s)), s).rgb;
}

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

// The point of the segment a b in front of or behind (on the same ray as) screen point a + t (b - a),
// perspective-corrected by the clip w's.
vec3 under(vec3 a, vec3 b, float t) {
    float wa = (u_view_projection * vec4(a, 1.0)).w, wb = (u_view_projection * vec4(b, 1.0)).w;
    float den = (1.0 - t) * wb + t * wa;
    return mix(a, b, den != 0.0 ? t * wa / den : t);
}

vec3 ray_direction(vec3 p) {  // the view ray through p
#ifdef CAMERA_ORTHOGRAPHIC
    return u_forward;
#else
    return normalize(p - u_eye);
#endif
}

void shirley_tuchman(Cell v, vec2 h0, vec2 h1, vec2 h2, vec2 h3, bool quad, int inner) {
    uint cell = v_entry[0] & ~COVER_ALL;
    vec4 linear = cell_texel(cell, 5u);
    // The thick vertex and the two ends of the cell's thickest piece along its ray.  Class 1: the inner
    // vertex and where its ray meets the opposite face (face k is opposite vertex k); class 2: where
    // the diagonals h0 h2 and h1 h3 cross on screen, the points of the two edges under it.  No
    // clipping against all four planes: a ray through a vertex or along an edge ties there.
    vec2 thick;
    vec3 x0, x1;
    if (quad) {
        vec2 e = h2 - h0, f = h3 - h1, g = h1 - h0;
        float den = e.x * f.y - e.y * f.x;
        float t = abs(den) > 0.0 ? clamp((g.x * f.y - g.y * f.x) / den, 0.0, 1.0) : 0.5;
        float u = abs(den) > 0.0 ? clamp((g.x * e.y - g.y * e.x) / den, 0.0, 1.0) : 0.5;
        thick = h0 + e * t;
        x0 = under(point_of(v, h0), point_of(v, h2), t);
        x1 = under(point_of(v, h1), point_of(v, h3), u);
    } else {
        uint k = uint(inner);
        thick = inner == 0 ? v.q0 : (inner == 1 ? v.q1 : (inner == 2 ? v.q2 : v.q3));
        x0 = inner == 0 ? v.p0 : (inner == 1 ? v.p1 : (inner == 2 ? v.p2 : v.p3));
        vec4 plane = cell_texel(cell, k);
        vec3 d = ray_direction(x0);
        float nd = dot(plane.xyz, d);
        x1 = x0 + (nd != 0.0 ? (plane.w - dot(plane.xyz, x0)) / nd : 0.0) * d;
    }
    vec3 d = ray_direction(x0);
    if (dot(x1 - x0, d) < 0.0) { vec3 x = x0; x0 = x1; x1 = x; }  // x0 in front
    float len = length(x1 - x0);
    float s_front = dot(linear.xyz, x0) + linear.w;
    float s_back = dot(linear.xyz, x1) + linear.w;
    vec4 piece = len > 0.0 ? transfer_segment(s_front, s_back, len) : vec4(0.0);
    float tau = piece.a < 1e-4 ? piece.a * (1.0 + 0.5 * piece.a) : -log(1.0 - piece.a);
    float s_mid = 0.5 * (s_front + s_back);
    vec3 colour = piece.a > 0.0 ? piece.rgb / piece.a : tf_in(tf_interval_at(tf_interval(s_mid)), s_mid).rgb;
    vec4 at_thick = vec4(colour, tau);
    cell_tau_max = tau;
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
    uvec4 ids = mesh_cell(v_entry[0]);
    vec2 q0, q1, q2, q3;
    vec3 p0 = mesh_point(ids.x).xyz, p1 = mesh_point(ids.y).xyz, p2 = mesh_point(ids.z).xyz, p3 = mesh_point(ids.w).xyz;
    {
        vec4 c0 = u_view_projection * vec4(p0, 1.0);
        vec4 c1 = u_view_projection * vec4(p1, 1.0);
        vec4 c2 = u_view_projection * vec4(p2, 1.0);
        vec4 c3 = u_view_projection * vec4(p3, 1.0);
        q0 = (c0.xy / c0.w * 0.5 + 0.5) * u_image_size;  // pixels
        q1 = (c1.xy / c1.w * 0.5 + 0.5) * u_image_size;
        q2 = (c2.xy / c2.w * 0.5 + 0.5) * u_image_size;
        q3 = (c3.xy / c3.w * 0.5 + 0.5) * u_image_size;
    }
    // The silhouette, counter-clockwise: h0 h1 h2 (h3).  Named vectors, not a dynamically indexed
    // array: llvmpipe runs several primitives per SIMD call, and a local array written at computed
    // indices under divergent branches came out wrong (corners repeated: pixels covered three times).
    vec2 h0 = q0, h1 = q1, h2 = q2, h3 = q3;
    int inner = 3;  // class 1: the vertex projecting inside the other three (the thick vertex)
    bool quad = true;
    if (inside(q3, q0, q1, q2)) { quad = false; }
    else if (inside(q2, q0, q1, q3)) { h2 = q3; quad = false; inner = 2; }
    else if (inside(q1, q0, q2, q3)) { h1 = q2; h2 = q3; quad = false; inner = 1; }
    else if (inside(q0, q1, q2, q3)) { h0 = q1; h1 = q2; h2 = q3; quad = false; inner = 0; }
    else if (orient(q0, q1, q2) * orient(q0, q1, q3) < 0.0) { h1 = q2; h2 = q1; }  // diagonal q0 q1
    else if (orient(q0, q2, q1) * orient(q0, q2, q3) >= 0.0) { h2 = q3; h3 = q2; } // diagonal q0 q3
    if (!quad) h3 = h2;
    float area = orient(h0, h1, h2) + (quad ? orient(h0, h2, h3) : 0.0);
    if (!(abs(area) > 0.0)) {  // flat: all four on a line (a cell seen edge on): its bounding box
#ifdef SHIRLEY_TUCHMAN
        return;  // no area: nothing of it is interpolated
#endif
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
#ifdef SHIRLEY_TUCHMAN
    shirley_tuchman(Cell(p0, p1, p2, p3, q0, q1, q2, q3), h0, h1, h2, h3, quad, inner);
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
