#version 430
// Projected tetrahedra, Shirley and Tuchman's fan built by a compute shader (SHIRLEY_TUCHMAN only):
// invocation i builds the fan of the cell in slot i of u_order (the visibility order, back to front)
// into rows 5 i to 5 i + 4 of the vertex buffer pt_fan.vert reads, in fan.py's layout (pixel x, y;
// colour; optical depth; the thick vertex's optical depth) padded to 8 floats: the thick vertex, then the silhouette's
// corners h0 h1 h2 h3 (a triangle's h0 again as its h3).  The renderer's fixed index buffer draws
// slot after slot, so the order holds, with pt.geom's triangles vertex for vertex: the same picture.
// The classification and the thick vertex are pt.geom's (pt_silhouette.glsl).  llvmpipe runs compute
// shaders on its thread pool, where the geometry stage runs on the calling thread.
layout(local_size_x = 64) in;

#include "mesh_fetch.glsl"
#include "transfer_segment.glsl"
#include "pt_silhouette.glsl"

uniform usampler2D u_order;  // slot -> cell, 4096 a row
uniform uint u_slots;        // the cells drawn

// A row is fan.py's 7 floats and one of padding, written as two vec4s: llvmpipe stores each lane's
// value of a store on its own, and 2 stores a row instead of 7 made this pass 18 % shorter on the jaw.
layout(std430, binding = 0) writeonly buffer Fan { vec4 rows[]; };

const uint CELL_VERTICES = 5u;

void put(uint row, vec2 pixel, vec4 st, float tau_max) {
    rows[2u * row] = vec4(pixel, st.r, st.g);
    rows[2u * row + 1u] = vec4(st.b, st.a, tau_max, 0.0);
}

void main() {  // the dispatch is up to 65535 groups wide, rows of them for more
    uint slot = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    if (slot >= u_slots) return;
    uint cell = texelFetch(u_order, texel_of(slot), 0).r;
    uint row = CELL_VERTICES * slot;
    Cell v = projected_cell(cell);
    vec2 h0, h1, h2, h3;
    int inner;
    bool quad;
    if (!silhouette(v, h0, h1, h2, h3, inner, quad)) {  // no area: five equal points, nothing drawn
        for (uint m = 0u; m < CELL_VERTICES; ++m) put(row + m, v.q0, vec4(0.0), 0.0);
        return;
    }
    vec4 linear = cell_texel(cell, 5u);
    vec2 thick;
    vec4 at_thick = thick_vertex(v, cell, linear, h0, h1, h2, h3, quad, inner, thick);
    float tau = at_thick.a;
    if (!quad) h3 = h0;  // a triangle's fourth triangle (thick h3 h0) has no area
    put(row, thick, at_thick, tau);
    put(row + 1u, h0, vec4(vertex_colour(point_of(v, h0), linear), 0.0), tau);
    put(row + 2u, h1, vec4(vertex_colour(point_of(v, h1), linear), 0.0), tau);
    put(row + 3u, h2, vec4(vertex_colour(point_of(v, h2), linear), 0.0), tau);
    put(row + 4u, h3, vec4(vertex_colour(point_of(v, h3), linear), 0.0), tau);
}
