// A convex polygon grown by u_margin pixels in screen space, every edge moved out by the margin:
// the rasterizer snaps vertices to a sub-pixel grid (llvmpipe: 1/256 pixel), so a pixel centre
// just inside a polygon can fall outside the drawn one.  Used by pt.geom (cells' footprints) and
// entry_lists.geom (the boundary's faces); what a grown polygon covers beyond the true one is
// tested per fragment by the caller.
uniform float u_margin;  // pixels

float orient(vec2 a, vec2 b, vec2 c) { return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x); }

vec2 outward(vec2 a, vec2 b) {  // the outward unit normal of edge a -> b of a counter-clockwise polygon
    vec2 e = vec2(b.y - a.y, a.x - b.x);
    float len = length(e);
    return len > 0.0 ? e / len : vec2(0.0);
}

// corner p with incoming and outgoing edge normals n_in, n_out: its points on the grown outline
void grow(vec2 p, vec2 n_in, vec2 n_out, out vec2 a, out vec2 b) {
    float c = dot(n_in, n_out);
    if (c >= 0.0) {
        a = p + u_margin * (n_in + n_out) / (1.0 + c);
        b = a;
    } else {
        a = p + u_margin * n_in;
        b = p + u_margin * n_out;
    }
}
