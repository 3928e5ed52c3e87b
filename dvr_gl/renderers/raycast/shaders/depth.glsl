// DEPTH: the pixel's depth beside its colour (docs/picking.md; dvr_gl.reference.depth is the judge).  The
// mode parts set depth_t, the ray parameter of the depth: where the optical depth reaches ln 2 (opacity one
// half: emission.glsl), the extremum's sample (projection.glsl), the refined hit (isosurface.glsl).  Written
// as the distance along the view axis from the eye's plane (OpenEXR's Z), 3e38 where the ray has none.

float pixel_depth() {
#ifdef GEOMETRY
    if (depth_t < 0.0) {  // an opaque mesh the volume did not hide: the mesh's depth
        float surface = texelFetch(u_geometry, ivec2(gl_FragCoord.xy), 0).a;
        if (surface < 3.0e38) depth_t = surface;
    }
#endif
    return depth_t < 0.0 ? 3.0e38 : dot(o + depth_t * d - u_eye, u_forward);
}
