#version 330 core
// One fragment of one slice of the texture-slicing renderers (the grid kit's slicing.py):
// the slices are drawn back to front and blended with the over operator on premultiplied colour
// (GL_ONE, GL_ONE_MINUS_SRC_ALPHA).  A slice stands for the slab to the next slice along this
// pixel's ray, of length spacing / |cos| (per fragment: under perspective every pixel's ray meets
// the slices at its own angle): opacity correction for that length; pre-integrated slabs read the
// scalar here and where the ray meets the next slice.
//   STACK: 2D texture stacks (object-aligned slices of a texture array); else 3D texture slicing.
//   classification and options as in common/classify.glsl; CLIPPING: fragments outside the kept region
//   are discarded (common/clipping.glsl); GEOMETRY: so are those behind an opaque mesh.
//   FIELDS (3D only): several fields, each sampled in its own texture and grid at the fragment, classified
//   and mixed (common/fields.glsl: NUM_FIELDS, NUM_FIELD_GROUPS, ...); the slices span the union box.

#if defined(SHADING) || defined(GRADIENT_OPACITY)
#define NEEDS_GRADIENT
#endif

#ifdef STACK
#include "common/stack_sample.glsl"
#else
#include "common/volume_sample.glsl"
#endif
#include "common/gradient.glsl"
#include "common/transfer_function.glsl"
#include "common/optics.glsl"
#include "common/shading.glsl"

uniform vec3 u_eye;
uniform vec3 u_forward;
uniform vec3 u_slice_normal;      // view axis (3D) or the stack's axis (2D)
uniform float u_slab_length;      // the slice spacing, world units
uniform float u_gradient_reference;
uniform vec3 u_box_lo;             // SCATTERING: where the lights' rays enter the volume
uniform vec3 u_box_hi;

// box.glsl and preintegration.glsl here, not first inside #ifdef FIELDS: a file is expanded once, where it
// is first named (classify.glsl names preintegration.glsl too)
#include "common/box.glsl"
#ifdef CLASSIFY_PREINTEGRATED
#include "common/preintegration.glsl"
#endif
#ifdef FIELDS
#include "common/fields.glsl"
#else
#include "common/classify.glsl"
// A slab's end value (pre-integration): one field's; several fields' is every member's (fields.glsl).
#define SegmentValue float
#define segment_value sample_scalar
#endif
#ifdef CLIPPING
#include "common/clipping.glsl"
#endif
#ifdef GEOMETRY
uniform sampler2D u_geometry;      // dvr_gl/renderers/surfaces.py: a = the nearest surface's t
#endif

in vec3 world;
out vec4 frag_color;

void main() {
#ifdef CLIPPING
    if (!clip_inside(world)) discard;  // per sample: the slice's fragment is the sample
#endif
#ifdef GEOMETRY
  #ifdef CAMERA_ORTHOGRAPHIC
    float t_here = dot(world - u_eye, u_forward);
  #else
    float t_here = length(world - u_eye);
  #endif
    if (t_here > texelFetch(u_geometry, ivec2(gl_FragCoord.xy), 0).a) discard;  // behind a surface
#endif
#ifdef CAMERA_ORTHOGRAPHIC
    vec3 dir = u_forward;
#else
    vec3 dir = normalize(world - u_eye);
#endif
    float len = u_slab_length / abs(dot(dir, u_slice_normal));
#ifdef CLASSIFY_PREINTEGRATED
    vec4 e = preintegrated_segment(segment_value(world), segment_value(world + len * dir), len, world, dir);
    frag_color = vec4(e.rgb, opacity_of_depth(e.a));
#else
    vec4 cs = classify(world, dir);
    float alpha = opacity_of_depth(cs.a * len);
    frag_color = vec4(cs.rgb * alpha, alpha);
#endif
}
