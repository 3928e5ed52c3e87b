// The mesh in textures, 4096 texels a row: u_points (x, y, z relative to the mesh centre, 0),
// u_cells (four point indices), u_cell_planes (six texels a cell: the planes of its faces 0 to 3
// (n, h), the side of each plane its inside lies on, its scalar as g . p + c).
uniform sampler2D u_points;
uniform usampler2D u_cells;
uniform sampler2D u_cell_planes;

const uint ROW = 4096u;
#ifdef FOLDED_PLANES
const uint CELL_TEXELS = 5u;  // each plane times its side (inside: n . p - h >= 0), the scalar
#else
const uint CELL_TEXELS = 6u;
#endif

ivec2 texel_of(uint i) { return ivec2(int(i % ROW), int(i / ROW)); }
vec4 mesh_point(uint i) { return texelFetch(u_points, texel_of(i), 0); }
uvec4 mesh_cell(uint c) { return texelFetch(u_cells, texel_of(c), 0); }
vec4 cell_texel(uint c, uint k) { return texelFetch(u_cell_planes, texel_of(c * CELL_TEXELS + k), 0); }
