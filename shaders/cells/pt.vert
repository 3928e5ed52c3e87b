#version 430
// Projected tetrahedra: one point per cell, in visibility order; the geometry shader draws its
// footprint (dvr_gl/renderers/projected_tetrahedra).
layout(location = 0) in uint in_cell;
flat out uint v_cell;

void main() {
    v_cell = in_cell;
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
