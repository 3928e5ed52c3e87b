// A ray clipped against a cell's face planes (pt.frag per fragment, pt.geom at the thick vertex
// of SHIRLEY_TUCHMAN).

// Clip the ray against one face: inside is side * (n . p - h) >= 0.  Face k's plane comes from its
// vertices in the order of their global indices, in float64 on the host, so the two cells sharing
// a face hold the same plane to the last bit (dvr_gl/fields/mesh_rays.py does the same).
void clip_face(vec4 plane, float side, vec3 o, vec3 d, inout float t_in, inout float t_out) {
    float nd = dot(plane.xyz, d) * side;
    float no = (dot(plane.xyz, o) - plane.w) * side;
    if (nd > 0.0) t_in = max(t_in, -no / nd);
    else if (nd < 0.0) t_out = min(t_out, -no / nd);
    else if (no < 0.0 || (no == 0.0 && side < 0.0)) t_out = -3.0e38;  // parallel and outside
}
