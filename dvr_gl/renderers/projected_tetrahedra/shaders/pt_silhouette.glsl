// Projected tetrahedra: a cell's projection classified (Shirley and Tuchman's class 1 or 2, the
// silhouette counter-clockwise) and, for SHIRLEY_TUCHMAN, its thick vertex's colour and optical
// depth.  One copy for the two places that build footprints: pt.geom (a point a cell) and
// pt_fan.comp (the fan built by a compute shader).  Include after mesh_fetch.glsl (and, for
// SHIRLEY_TUCHMAN, transfer_segment.glsl).
#include "grow.glsl"

uniform mat4 u_view_projection;  // centre-relative world -> clip
uniform vec2 u_image_size;

bool inside(vec2 p, vec2 a, vec2 b, vec2 c) {  // p in the triangle abc, either orientation
    float u = orient(a, b, p), v = orient(b, c, p), w = orient(c, a, p);
    return (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
}

// The cell's vertices (centre-relative), fetched once, and their projections (pixels).
struct Cell { vec3 p0, p1, p2, p3; vec2 q0, q1, q2, q3; };

Cell projected_cell(uint cell) {
    uvec4 ids = mesh_cell(cell);
    vec3 p0 = mesh_point(ids.x).xyz, p1 = mesh_point(ids.y).xyz, p2 = mesh_point(ids.z).xyz, p3 = mesh_point(ids.w).xyz;
    vec4 c0 = u_view_projection * vec4(p0, 1.0);
    vec4 c1 = u_view_projection * vec4(p1, 1.0);
    vec4 c2 = u_view_projection * vec4(p2, 1.0);
    vec4 c3 = u_view_projection * vec4(p3, 1.0);
    return Cell(p0, p1, p2, p3, (c0.xy / c0.w * 0.5 + 0.5) * u_image_size, (c1.xy / c1.w * 0.5 + 0.5) * u_image_size,
                (c2.xy / c2.w * 0.5 + 0.5) * u_image_size, (c3.xy / c3.w * 0.5 + 0.5) * u_image_size);
}

// The silhouette, counter-clockwise: h0 h1 h2 (h3; a triangle's h3 is its h2), quad for class 2, inner
// the vertex projecting inside the other three for class 1 (the thick vertex); false when it has no
// area (all four on a line: a cell seen edge on).  Named vectors, not a dynamically indexed array:
// llvmpipe runs several primitives per SIMD call, and a local array written at computed indices under
// divergent branches came out wrong (corners repeated: pixels covered three times).
bool silhouette(Cell v, out vec2 h0, out vec2 h1, out vec2 h2, out vec2 h3, out int inner, out bool quad) {
    vec2 q0 = v.q0, q1 = v.q1, q2 = v.q2, q3 = v.q3;
    h0 = q0; h1 = q1; h2 = q2; h3 = q3;
    inner = 3;
    quad = true;
    if (inside(q3, q0, q1, q2)) { quad = false; }
    else if (inside(q2, q0, q1, q3)) { h2 = q3; quad = false; inner = 2; }
    else if (inside(q1, q0, q2, q3)) { h1 = q2; h2 = q3; quad = false; inner = 1; }
    else if (inside(q0, q1, q2, q3)) { h0 = q1; h1 = q2; h2 = q3; quad = false; inner = 0; }
    else if (orient(q0, q1, q2) * orient(q0, q1, q3) < 0.0) { h1 = q2; h2 = q1; }  // diagonal q0 q1
    else if (orient(q0, q2, q1) * orient(q0, q2, q3) >= 0.0) { h2 = q3; h3 = q2; } // diagonal q0 q3
    if (!quad) h3 = h2;
    float area = orient(h0, h1, h2) + (quad ? orient(h0, h2, h3) : 0.0);
    if (!(abs(area) > 0.0)) return false;
    if (area < 0.0) {  // clockwise: reverse
        vec2 t = h1;
        h1 = quad ? h3 : h2;
        if (quad) h3 = t; else { h2 = t; h3 = t; }
    }
    return true;
}

#ifdef SHIRLEY_TUCHMAN
uniform vec3 u_eye;      // relative to the mesh's centre, as the points
uniform vec3 u_forward;

vec3 point_of(Cell v, vec2 h) {  // the vertex a silhouette corner is
    return h == v.q0 ? v.p0 : (h == v.q1 ? v.p1 : (h == v.q2 ? v.p2 : v.p3));
}

vec3 vertex_colour(vec3 p, vec4 linear) {  // the transfer function's colour at a vertex's scalar
    float s = dot(linear.xyz, p) + linear.w;
    return tf_in(tf_interval_at(tf_interval(s)), s).rgb;
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

// The thick vertex (pixels) and its colour and optical depth: the exact integral along the cell's
// thickest piece on its ray (colour the integral's over its opacity, or the transfer function's at
// the piece's middle where it has none).  Class 1: the inner vertex and where its ray meets the
// opposite face (face k is opposite vertex k); class 2: where the diagonals h0 h2 and h1 h3 cross on
// screen, the points of the two edges under it.  No clipping against all four planes: a ray through a
// vertex or along an edge ties there.  ``linear``: the cell's scalar as g . p + c.
vec4 thick_vertex(Cell v, uint cell, vec4 linear, vec2 h0, vec2 h1, vec2 h2, vec2 h3, bool quad, int inner,
                  out vec2 thick) {
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
    return vec4(colour, tau);
}
#endif
