#version 430
// Projected tetrahedra: one point per cell in visibility order (no vertex buffer: point i is slot i
// of u_order); the geometry shader draws the cell's footprint (dvr_gl/renderers/projected_tetrahedra).
#include "mesh_fetch.glsl"

uniform usampler2D u_order;  // slot -> cell (the high bit: COVER_ALL), 4096 a row

flat out uint v_entry;

void main() {
    v_entry = texelFetch(u_order, texel_of(uint(gl_VertexID)), 0).r;
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
