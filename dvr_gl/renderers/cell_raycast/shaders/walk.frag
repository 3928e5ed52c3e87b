#version 430
// Ray casting from cell to cell (Garrity 1990; Weiler et al. 2003 on the GPU): each pixel's ray
// enters the mesh at the entering boundary faces of its list (entry_lists.frag), nearest first,
// and walks through the cells by their face neighbours: clip against the cell's four face planes
// (as pt.frag), the scalar linear along the piece inside, and
//   EMISSION: the emission-absorption integral of the exact transfer function along the piece
//     (transfer_segment.glsl), composited front to back, until the opacity reaches u_opaque;
//   MIP, MINIP: the larger (smaller) end value; AVERAGE: the integral of the value;
//   ISOSURFACE: the first point where the value reaches the iso-value (its t), then done.
// Projections keep a coverage flag in .g; the host classifies the value (mesh_gl.py).
// Where the ray leaves the mesh it goes on at the next entry beyond its exit: no visibility order,
// no footprints.  START_CELLS: the mesh reaches the near plane, and the cell holding each ray's
// start (located on the host) is walked first.  CLIPPING and GEOMETRY: each piece is narrowed to
// the ray's kept part [t_lo, t_hi] (kept_part.glsl), and the walk ends once it has passed t_hi.
#include "common/camera_ray.glsl"
#include "mesh_fetch.glsl"
#include "kept_part.glsl"
#ifdef EMISSION
#include "transfer_segment.glsl"
#endif

uniform isampler2D u_neighbours;  // the cell across each face, -1: the boundary
#ifdef START_CELLS
uniform usampler2D u_start;       // the cell holding the ray's start + 1, 0: none
#endif
layout(std430, binding = 0) readonly buffer Nodes { uvec4 nodes[]; };
layout(r32ui, binding = 0) uniform readonly uimage2D u_heads;
uniform float u_touching;  // an entry this close before the last exit meets it (duplicated interfaces)
uniform float u_opaque;    // EMISSION: early ray termination at this opacity
uniform float u_iso_value;

out vec4 frag;

// Entries sorted a round at a time (a private array per lane: llvmpipe keeps it in memory, so a
// short one); a ray with more entering faces takes more rounds.
const int ENTRIES = 16;
// Steps through cells the ray only touches (an edge, a vertex) do not advance; rounding can send
// such steps round in a cycle, which llvmpipe's loop cap (65535 iterations a SIMD group) would end
// for the neighbouring pixels too: the walk gives up after this many in a row (the next entry
// takes over).
const int MAX_STALLS = 32;

vec4 acc;   // see the modes above
bool done;
float t_lo, t_hi;  // the ray's kept part (all of it without CLIPPING and GEOMETRY)
vec4 walk_stats;  // WALK_STATS: steps, walks, walks given up, the last t reached

void piece(float sf, float sb, float a, float b) {
#if defined(EMISSION)
    acc += (1.0 - acc.a) * transfer_segment(sf, sb, b - a);
    done = acc.a >= u_opaque;
#elif defined(MIP)
    acc.rg = vec2(max(acc.r, max(sf, sb)), 1.0);
#elif defined(MINIP)
    acc.rg = vec2(min(acc.r, min(sf, sb)), -1.0);
#elif defined(AVERAGE)
    acc.rg = vec2(acc.r + 0.5 * (b - a) * (sf + sb), 1.0);
#elif defined(ISOSURFACE)
    if (max(sf, sb) >= u_iso_value) {
        // the first point with value >= iso: the front itself when it is already there
        acc.rg = vec2(sf >= u_iso_value ? a : a + (b - a) * (u_iso_value - sf) / (sb - sf), 1.0);
        done = true;
    }
#endif
}

// From `cell`, on from t_prev (the farthest point reached): pieces and steps into the neighbour
// across the exit face, until the ray leaves the mesh (t_prev: where) or is done.
void walk(uint cell, vec3 o, vec3 d, inout float t_prev) {
    int stalls = 0;  // steps in a row that did not advance along the ray
    // An entry whose cell the ray clearly misses is one the ray only touches (a boundary edge two
    // entering faces share, rays along the oxygen post's axis): walking on from it wandered through
    // cells beside the ray, found the ray again further on and skipped the cells between.  Such an
    // entry is given up at once; the ray's other entry there (the face it does cross) takes over.
    walk_stats.y += 1.0;
    for (int i = 0; i < 65535; ++i) {
        walk_stats.x += 1.0;
        // the planes with their sides folded in (FOLDED_PLANES): inside is n . p - h >= 0
        vec4 p0 = cell_texel(cell, 0u), p1 = cell_texel(cell, 1u), p2 = cell_texel(cell, 2u);
        vec4 p3 = cell_texel(cell, 3u), lin = cell_texel(cell, 4u);
        vec4 nd = vec4(dot(p0.xyz, d), dot(p1.xyz, d), dot(p2.xyz, d), dot(p3.xyz, d));
        vec4 no = vec4(dot(p0.xyz, o), dot(p1.xyz, o), dot(p2.xyz, o), dot(p3.xyz, o)) - vec4(p0.w, p1.w, p2.w, p3.w);
        vec4 t = -no / nd;  // inf or NaN where nd = 0: never selected below
        vec4 t_in = mix(vec4(-3.0e38), t, greaterThan(nd, vec4(0.0)));
        vec4 t_out = mix(vec4(3.0e38), t, lessThan(nd, vec4(0.0)));
        float a = max(max(max(t_in.x, t_in.y), max(t_in.z, t_in.w)), t_prev);
        float b = min(min(t_out.x, t_out.y), min(t_out.z, t_out.w));
        if (!(b < 3.0e38)) break;  // no face to leave by: a cell without extent
        int k = b == t_out.x ? 0 : b == t_out.y ? 1 : b == t_out.z ? 2 : 3;
        if (i == 0 && a > b + u_touching) break;  // see above
        float ka = max(a, t_lo), kb = min(b, t_hi);  // the piece's kept part
        if (kb > ka) {
            piece(dot(lin.xyz, o + ka * d) + lin.w, dot(lin.xyz, o + kb * d) + lin.w, ka, kb);
            if (done) break;
        }
        // Only a piece moves the ray on: a cell the ray passes beside (rounding at an edge sent the
        // walk there) says nothing of the stretch up to its leaving face, which lies in other cells.
        bool advanced = b > a;
        stalls = advanced ? 0 : stalls + 1;
        if (stalls > MAX_STALLS) { walk_stats.z += 1.0; break; }
        if (advanced) t_prev = b;
        if (t_prev >= t_hi) { done = true; break; }  // nothing kept beyond
        int next = texelFetch(u_neighbours, texel_of(cell), 0)[k];
        if (next < 0) break;
        cell = uint(next);
    }
}

void main() {
    vec3 o, d;
    camera_ray(o, d);
#if defined(MIP)
    acc = vec4(-3.0e38, 0.0, 0.0, 0.0);
#elif defined(MINIP)
    acc = vec4(3.0e38, 0.0, 0.0, 0.0);
#else
    acc = vec4(0.0);
#endif
    walk_stats = vec4(0.0);
    float t_prev = max(near_distance(d), 0.0);
    t_lo = -3.0e38;
    t_hi = 3.0e38;
    kept_part(o, d, t_lo, t_hi);
    done = !(t_hi > max(t_lo, t_prev));  // nothing of this ray is kept
#ifdef START_CELLS
    uint start = texelFetch(u_start, ivec2(gl_FragCoord.xy), 0).r;
    if (start != 0u && !done) walk(start - 1u, o, d, t_prev);
#endif
    uint head = imageLoad(u_heads, ivec2(gl_FragCoord.xy)).r;
    // the entries taken so far end at (cut_t, cut_node): (t, node) orders them, ties included
    float cut_t = -3.0e38;
    uint cut_node = 0u;
    bool more = head != 0u;
    while (more && !done) {
        float entry_t[ENTRIES];
        uint entry_cell[ENTRIES], entry_node[ENTRIES];
        int count = 0;
        more = false;
        for (uint node = head; node != 0u; ) {  // the ENTRIES nearest beyond the cut, by insertion
            uvec4 n = nodes[node - 1u];
            float t = uintBitsToFloat(n.y);
            if (t > cut_t || (t == cut_t && node > cut_node)) {
                int j = count;
                if (count == ENTRIES) {
                    more = true;  // some wait for the next round
                    j = ENTRIES - 1;
                    if (t > entry_t[j] || (t == entry_t[j] && node > entry_node[j])) j = -1;
                } else {
                    ++count;
                }
                while (j > 0 && (entry_t[j - 1] > t || (entry_t[j - 1] == t && entry_node[j - 1] > node))) {
                    entry_t[j] = entry_t[j - 1];
                    entry_cell[j] = entry_cell[j - 1];
                    entry_node[j] = entry_node[j - 1];
                    --j;
                }
                if (j >= 0) {
                    entry_t[j] = t;
                    entry_cell[j] = n.x;
                    entry_node[j] = node;
                }
            }
            node = n.z;
        }
        for (int e = 0; e < count && !done; ++e)
            if (entry_t[e] > t_prev - u_touching) walk(entry_cell[e], o, d, t_prev);  // else passed already
        if (count > 0) {
            cut_t = entry_t[count - 1];
            cut_node = entry_node[count - 1];
        }
    }
    frag = acc;
#ifdef WALK_STATS
    frag = vec4(walk_stats.xyz, t_prev);
#endif
}
