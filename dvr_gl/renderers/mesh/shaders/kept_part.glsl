// The part of a fragment's ray the mesh renderers integrate (dvr_gl/renderers/mesh/textures.py):
// CLIPPING narrows it to the clipping planes and the cropping box (common/clipping.glsl, the
// region given relative to the mesh's centre, as the rays are); GEOMETRY ends it at the nearest
// opaque surface (dvr_gl/renderers/surfaces.py: a = its t along the pixel's ray, 3e38: none).
// The references narrow their rays the same way (dvr_gl/clipping.py, dvr_gl/geometry.py).
#ifdef CLIPPING
#include "common/clipping.glsl"
#endif
#ifdef GEOMETRY
uniform sampler2D u_geometry;
#endif

void kept_part(vec3 o, vec3 d, inout float t0, inout float t1) {
#ifdef CLIPPING
    clip_interval(o, d, t0, t1);
#endif
#ifdef GEOMETRY
    t1 = min(t1, texelFetch(u_geometry, ivec2(gl_FragCoord.xy), 0).a);
#endif
}
