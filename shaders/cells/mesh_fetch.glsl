// The mesh in textures, 4096 texels a row: u_points (x, y, z relative to the mesh centre, value),
// u_cells (four point indices), u_linear (the cell's scalar as g . p + c: g, c).
uniform sampler2D u_points;
uniform usampler2D u_cells;
uniform sampler2D u_linear;

const uint ROW = 4096u;

ivec2 texel_of(uint i) { return ivec2(int(i % ROW), int(i / ROW)); }
vec4 mesh_point(uint i) { return texelFetch(u_points, texel_of(i), 0); }
uvec4 mesh_cell(uint c) { return texelFetch(u_cells, texel_of(c), 0); }
vec4 mesh_linear(uint c) { return texelFetch(u_linear, texel_of(c), 0); }
