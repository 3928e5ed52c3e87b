// Several fields (dvr_gl.fields.layers): every member sampled in its own grid and classified by its own
// transfer function, then mixed per sample (docs/several-fields.md): extinctions add, emissions add,
// sigma = sum_i sigma_i, sigma c = sum_i sigma_i c_i, each member only inside its own box (closed).
// Replaces classify() of common/classify.glsl (same signature), and gives the per-member values the
// compositing modes need.  The textures and their uniforms: dvr_gl/renderers/grid/field_textures.py.
//   NUM_FIELDS (members), NUM_FIELD_GROUPS (textures), FIELD_GROUP_OF and FIELD_CHANNEL_OF (each member's
//   texture and channel, constant lists: GLSL 3.30 indexes samplers by constants only), FIELD_EACH(M) (the
//   members' loop written out: M(0) M(1) ... M(NUM_FIELDS - 1))
//   FIELD_TABLES_2D with FIELD_TABLE_2D_OF (1 for a member classified by value and gradient magnitude,
//   common/transfer_function_2d.glsl; its table in u_field_tf2d, dvr_gl/renderers/raycast/fields.py's Tables2D)
// Needs: volume_sample.glsl (sample_texture_in), transfer_function.glsl's neighbours optics.glsl and
// shading.glsl, and u_gradient_reference (GRADIENT_OPACITY).  Gradients are central differences one voxel
// of the member's grid apart (world units), as dvr_gl.reference takes them; gradient = "texture" gives the
// same field (the filters are linear in the samples), so several fields always take them here.
//   FIELDS_ORIENTED: some member's direction differs from the first's (dvr_gl.fields.layers): group g's
//   texture is read at q = u_field_turn[g] * p + u_field_shift[g], p in the shared frame, q in its own frame
//   (identity and zero for the others); its box is tested, and its gradient taken, there, the gradient turned
//   back by transpose(u_field_turn[g]).  Without it (every direction the same) the code is the one of old.

#if defined(FIELD_TABLES_2D) && !defined(NEEDS_GRADIENT)
#define NEEDS_GRADIENT  // a 2D member's table reads its gradient's magnitude
#endif

uniform sampler3D u_field_group[NUM_FIELD_GROUPS];
uniform vec3 u_field_scale[NUM_FIELD_GROUPS];    // group voxel = world * scale + offset
uniform vec3 u_field_offset[NUM_FIELD_GROUPS];
uniform vec3 u_field_dims[NUM_FIELD_GROUPS];     // voxels along x, y, z (as floats)
uniform vec3 u_field_spacing[NUM_FIELD_GROUPS];  // world units per voxel
uniform vec3 u_field_box_lo[NUM_FIELD_GROUPS];   // where the group's members contribute (world units)
uniform vec3 u_field_box_hi[NUM_FIELD_GROUPS];
uniform float u_field_value_scale[NUM_FIELDS];   // member's data value = texel * scale + offset
#ifdef FIELDS_ORIENTED
uniform mat3 u_field_turn[NUM_FIELD_GROUPS];     // shared frame -> the group's own frame: q = turn p + shift
uniform vec3 u_field_shift[NUM_FIELD_GROUPS];
#define FIELD_OWN(G, P) (u_field_turn[G] * (P) + u_field_shift[G])
#else
#define FIELD_OWN(G, P) (P)
#endif
uniform float u_field_value_offset[NUM_FIELDS];

uniform sampler2D u_field_lut;                   // one row per member: (r, g, b, sigma) at N values
uniform int u_field_lut_size;
uniform float u_field_lut_lo[NUM_FIELDS];        // data value of the row's texel 0
uniform float u_field_lut_scale[NUM_FIELDS];     // texels per data unit
uniform float u_field_unit_distance[NUM_FIELDS]; // projections: opacity over this length (world units)
#ifdef SHADING
// u_gradient_epsilon / member i's own (dvr_gl.fields.gradient_epsilon of its grid): its gradient, so scaled,
// meets blinn_phong's one threshold where it meets its own (the normal's direction is the same)
uniform float u_field_epsilon_scale[NUM_FIELDS];
#endif

const int FIELD_GROUP[NUM_FIELDS] = int[NUM_FIELDS](FIELD_GROUP_OF);
const int FIELD_CHANNEL[NUM_FIELDS] = int[NUM_FIELDS](FIELD_CHANNEL_OF);  // an rgb member's: 3, its x
const int FIELD_ROLE[NUM_FIELDS] = int[NUM_FIELDS](FIELD_ROLE_OF);  // 0 scalar, 1 label, 2 rgb

// The texels of every group at p (each in its own grid) and whether p lies in each group's box.
struct FieldTexels {
    vec4 t[NUM_FIELD_GROUPS];
    bool inside[NUM_FIELD_GROUPS];
};

// (P in group G's own frame)
#define FIELD_GROUP_TEXEL(G, P) sample_texture_in(u_field_group[G], (P) * u_field_scale[G] + u_field_offset[G], \
                                                  ivec3(u_field_dims[G]))

// Whether p lies in group g's box (closed; the box's faces on the union box's moved out by a margin on the host:
// FieldTextures.uniforms).
bool field_group_inside(int g, vec3 p) {
#ifdef FIELDS_SHARE_BOX
    return true;  // every member's box is the union box, which the samples lie in
#endif
    vec3 q = FIELD_OWN(g, p);
    return all(greaterThanEqual(q, u_field_box_lo[g])) && all(lessThanEqual(q, u_field_box_hi[g]));
}

// Group g's texels at point p of its own frame (g a constant after unrolling).
vec4 field_group_texels_own(int g, vec3 p) {
    // samplers by constant indices: one branch per group, the rest compiled out
    if (g == 0) return FIELD_GROUP_TEXEL(0, p);
#if NUM_FIELD_GROUPS > 1
    if (g == 1) return FIELD_GROUP_TEXEL(1, p);
#endif
#if NUM_FIELD_GROUPS > 2
    if (g == 2) return FIELD_GROUP_TEXEL(2, p);
#endif
#if NUM_FIELD_GROUPS > 3
    if (g == 3) return FIELD_GROUP_TEXEL(3, p);
#endif
#if NUM_FIELD_GROUPS > 4
    if (g == 4) return FIELD_GROUP_TEXEL(4, p);
#endif
#if NUM_FIELD_GROUPS > 5
    if (g == 5) return FIELD_GROUP_TEXEL(5, p);
#endif
    return vec4(0.0);
}

// Group g's texels at shared-frame point p.
vec4 field_group_texels(int g, vec3 p) {
    return field_group_texels_own(g, FIELD_OWN(g, p));
}

FieldTexels field_texels(vec3 p) {
    FieldTexels s;
    for (int g = 0; g < NUM_FIELD_GROUPS; ++g) {
        s.t[g] = field_group_texels(g, p);
        s.inside[g] = field_group_inside(g, p);
    }
    return s;
}

// Member i's data value from its group's texels.
float field_value(int i, vec4 texels) {
    return texels[FIELD_CHANNEL[i]] * u_field_value_scale[i] + u_field_value_offset[i];
}

float field_value_at(int i, FieldTexels s) {
    return field_value(i, s.t[FIELD_GROUP[i]]);
}

bool field_inside(int i, FieldTexels s) {
    return s.inside[FIELD_GROUP[i]];
}

// Member i's (non-associated colour, extinction per world unit) at a data value: its table's row,
// interpolated with a float weight as transfer_function() does.
vec4 field_transfer_function(int i, float value) {
    float x = clamp((value - u_field_lut_lo[i]) * u_field_lut_scale[i], 0.0, float(u_field_lut_size - 1));
    int i0 = min(int(floor(x)), u_field_lut_size - 2);
    return mix(texelFetch(u_field_lut, ivec2(i0, i), 0), texelFetch(u_field_lut, ivec2(i0 + 1, i), 0),
               x - float(i0));
}

#ifdef FIELD_LABELS
// Label members (common/labels.glsl: the label rule, never a label no tap holds) and their colour tables
// (dvr_gl/renderers/grid/field_textures.py's LabelAtlas: member i's label L at texel k = L - first, column
// k % width, row row_i + k / width).
#include "common/labels.glsl"

uniform sampler2D u_field_labels;
uniform int u_field_label_width;
uniform float u_field_label_first[NUM_FIELDS];
uniform float u_field_label_count[NUM_FIELDS];
uniform float u_field_label_row[NUM_FIELDS];

#define FIELD_LABEL_SAMPLE(G) label_sample(u_field_group[G], lg, p, gradient)

#ifdef FIELDS_ORIENTED
int field_label_own(int i, int g, vec3 p, out vec3 gradient);
#endif

// Member i's label at p and its indicator's gradient (per world unit, pointing into the label).
int field_label(int i, vec3 p, out vec3 gradient) {
    int g = FIELD_GROUP[i];
#ifdef FIELDS_ORIENTED
    int label = field_label_own(i, g, FIELD_OWN(g, p), gradient);
    gradient = gradient * u_field_turn[g];  // A^T g: back into the shared frame
    return label;
}

// Member i's label at point p of its group g's own frame and its indicator's gradient there.
int field_label_own(int i, int g, vec3 p, out vec3 gradient) {
#endif
    LabelGrid lg = label_grid(FIELD_CHANNEL[i], u_field_value_scale[i], u_field_value_offset[i],
                              ivec3(u_field_dims[g]), u_field_scale[g], u_field_offset[g]);
    if (g == 0) return FIELD_LABEL_SAMPLE(0);
#if NUM_FIELD_GROUPS > 1
    if (g == 1) return FIELD_LABEL_SAMPLE(1);
#endif
#if NUM_FIELD_GROUPS > 2
    if (g == 2) return FIELD_LABEL_SAMPLE(2);
#endif
#if NUM_FIELD_GROUPS > 3
    if (g == 3) return FIELD_LABEL_SAMPLE(3);
#endif
#if NUM_FIELD_GROUPS > 4
    if (g == 4) return FIELD_LABEL_SAMPLE(4);
#endif
#if NUM_FIELD_GROUPS > 5
    if (g == 5) return FIELD_LABEL_SAMPLE(5);
#endif
    gradient = vec3(0.0);
    return 0;
}

// (colour, sigma per world unit) of label L in member i's table; zero for a label the table does not list.
vec4 field_label_class(int i, int label) {
    int k = label - int(u_field_label_first[i]);
    if (k < 0 || k >= int(u_field_label_count[i])) return vec4(0.0);
    return texelFetch(u_field_labels, ivec2(k % u_field_label_width, int(u_field_label_row[i]) + k / u_field_label_width),
                      0);
}

// Member i's label classified at p, shaded by its indicator's gradient (no gradient opacity: a label map has
// no value to take a gradient of).
vec4 field_label_classify(int i, vec3 p, vec3 dir) {
    vec3 gradient;
    vec4 cs = field_label_class(i, field_label(i, p, gradient));
  #ifdef SHADING
    cs.rgb = blinn_phong(cs.rgb, gradient * u_field_epsilon_scale[i], dir);
  #endif
    return cs;
}

// 1 where member i's label at p is visible (listed with some opacity), else 0: what its isosurface is a
// level of (at one half).
float field_label_visible(int i, vec3 p) {
    vec3 gradient;
    return field_label_class(i, field_label(i, p, gradient)).a > 0.0 ? 1.0 : 0.0;
}
#endif

#ifdef NEEDS_GRADIENT
// Every group's channels' gradients at p (data units per world unit): central differences one voxel of
// the group's grid apart, x, y and z components of all four channels at once.
struct FieldGradients {
    vec4 x[NUM_FIELD_GROUPS];
    vec4 y[NUM_FIELD_GROUPS];
    vec4 z[NUM_FIELD_GROUPS];
};

FieldGradients field_gradients(vec3 p) {
    FieldGradients g;
    for (int k = 0; k < NUM_FIELD_GROUPS; ++k) {
        vec3 h = u_field_spacing[k];
#ifdef FIELDS_ORIENTED
        // along the group's own axes, then turned back: (x, y, z) = A^T (x', y', z') for all four channels
        vec3 q = FIELD_OWN(k, p);
        vec4 x = (field_group_texels_own(k, q + vec3(h.x, 0.0, 0.0)) - field_group_texels_own(k, q - vec3(h.x, 0.0, 0.0)))
                 / (2.0 * h.x);
        vec4 y = (field_group_texels_own(k, q + vec3(0.0, h.y, 0.0)) - field_group_texels_own(k, q - vec3(0.0, h.y, 0.0)))
                 / (2.0 * h.y);
        vec4 z = (field_group_texels_own(k, q + vec3(0.0, 0.0, h.z)) - field_group_texels_own(k, q - vec3(0.0, 0.0, h.z)))
                 / (2.0 * h.z);
        mat3 a = u_field_turn[k];
        g.x[k] = a[0][0] * x + a[0][1] * y + a[0][2] * z;
        g.y[k] = a[1][0] * x + a[1][1] * y + a[1][2] * z;
        g.z[k] = a[2][0] * x + a[2][1] * y + a[2][2] * z;
#else
        g.x[k] = (field_group_texels(k, p + vec3(h.x, 0.0, 0.0)) - field_group_texels(k, p - vec3(h.x, 0.0, 0.0)))
                 / (2.0 * h.x);
        g.y[k] = (field_group_texels(k, p + vec3(0.0, h.y, 0.0)) - field_group_texels(k, p - vec3(0.0, h.y, 0.0)))
                 / (2.0 * h.y);
        g.z[k] = (field_group_texels(k, p + vec3(0.0, 0.0, h.z)) - field_group_texels(k, p - vec3(0.0, 0.0, h.z)))
                 / (2.0 * h.z);
#endif
    }
    return g;
}

vec3 field_gradient(int i, FieldGradients g) {
    int k = FIELD_GROUP[i];
    int c = FIELD_CHANNEL[i];
    return vec3(g.x[k][c], g.y[k][c], g.z[k][c]) * u_field_value_scale[i];
}

// Member i's gradient alone at p (the isosurface's hit).
vec3 field_gradient_at(int i, vec3 p) {
    return field_gradient(i, field_gradients(p));
}
#endif

#ifdef FIELD_TABLES_2D
#include "common/transfer_function_2d.glsl"

const int FIELD_TABLE_2D[NUM_FIELDS] = int[NUM_FIELDS](FIELD_TABLE_2D_OF);
uniform sampler2D u_field_tf2d;             // the members' tables stacked: member i's NV x NG from its origin
uniform vec2 u_field_tf2d_origin[NUM_FIELDS];  // first texel (column, row)
uniform vec2 u_field_tf2d_size[NUM_FIELDS];    // (NV, NG)
uniform vec2 u_field_tf2d_lo[NUM_FIELDS];      // value and gradient magnitude of the first texel
uniform vec2 u_field_tf2d_scale[NUM_FIELDS];   // texels per data unit, per (value unit per world unit)

// Member i's 2D table at a value and gradient magnitude (non-associated colour, sigma per world unit).
vec4 field_transfer_function_2d(int i, float value, float gradient_magnitude) {
    return table_2d(u_field_tf2d, ivec2(u_field_tf2d_origin[i]), ivec2(u_field_tf2d_size[i]), u_field_tf2d_lo[i],
                    u_field_tf2d_scale[i], value, gradient_magnitude);
}
#endif

// Member i's (colour, sigma) at its value (a 2D member's: at its value and gradient magnitude; an rgb member's:
// its x, the colour the data's, never negative): gradient opacity scales sigma and shading shades the colour by
// its own gradient, as classify() does for one field.
vec4 field_classify_member(int i, vec4 texels, vec3 grad, vec3 dir) {
#ifdef FIELD_TABLES_2D
    vec4 tf = FIELD_TABLE_2D[i] == 1 ? field_transfer_function_2d(i, field_value(i, texels), length(grad))
                                     : field_transfer_function(i, field_value(i, texels));
#else
    vec4 tf = field_transfer_function(i, field_value(i, texels));
#endif
#ifdef FIELD_RGB
    if (FIELD_ROLE[i] == 2) tf.rgb = max(texels.rgb, 0.0);
#endif
#ifdef GRADIENT_OPACITY
    tf.a *= min(1.0, length(grad) / u_gradient_reference);
#endif
#ifdef SHADING
    tf.rgb = blinn_phong(tf.rgb, grad * u_field_epsilon_scale[i], dir);
#endif
    return tf;
}

// Member i's (non-associated colour, sigma) at p by its role (texels: its group's at p; grad: its gradient).
vec4 field_member_classify(int i, vec3 p, vec3 dir, vec4 texels, vec3 grad) {
#ifdef FIELD_LABELS
    if (FIELD_ROLE[i] == 1) return field_label_classify(i, p, dir);
#endif
    return field_classify_member(i, texels, grad, dir);
}

// The loops over the members are written out: FIELD_EACH(M) (a define, M(0) M(1) ... M(NUM_FIELDS - 1)) makes
// each member's index, hence its role, group and channel, a constant.  Mesa unrolls no loop whose body is this
// large, and a variable member index costs every sample dynamic indexing of every array here and the code of
// every role: written out, CT + labels took 0.3 of the time (docs/labels.md, "Cost").
#ifdef NEEDS_GRADIENT
#define FIELD_GRADIENT_OF(I) field_gradient(I, g)
#else
#define FIELD_GRADIENT_OF(I) vec3(0.0)
#endif

// Member I's part of the mixture at p (in classify()).
#define FIELD_MIX(I) \
    if (field_inside(I, s)) { \
        vec4 cs = field_member_classify(I, p, dir, s.t[FIELD_GROUP[I]], FIELD_GRADIENT_OF(I)); \
        emitted += cs.a * cs.rgb; \
        sigma += cs.a; \
    }

// The mixture's (non-associated colour, extinction) at p: extinctions add, emissions add.
vec4 classify(vec3 p, vec3 dir) {
    FieldTexels s = field_texels(p);
#ifdef NEEDS_GRADIENT
    FieldGradients g = field_gradients(p);
#endif
    vec3 emitted = vec3(0.0);
    float sigma = 0.0;
    FIELD_EACH(FIELD_MIX)
    return vec4(sigma > 0.0 ? emitted / sigma : vec3(0.0), sigma);
}

// ---- pre-integrated classification (CLASSIFY_PREINTEGRATED) ----

#ifdef CLASSIFY_PREINTEGRATED
// The values of every member at a point: a segment's end.
struct SegmentValue {
    float v[NUM_FIELDS];
};

SegmentValue segment_value(vec3 p) {
    FieldTexels s = field_texels(p);
    SegmentValue out_value;
    for (int i = 0; i < NUM_FIELDS; ++i) out_value.v[i] = field_value_at(i, s);
    return out_value;
}

uniform sampler2D u_field_preint;     // member i's N x N table in rows i N .. (i + 1) N - 1
uniform int u_field_preint_size;
uniform float u_field_preint_lo[NUM_FIELDS];
uniform float u_field_preint_scale[NUM_FIELDS];

// Member i's table entry (associated colour, optical depth) by the segment's end values.
vec4 field_preintegrated(int i, float front, float back) {
    float last = float(u_field_preint_size - 1);
    vec2 x = clamp((vec2(front, back) - u_field_preint_lo[i]) * u_field_preint_scale[i], 0.0, last);
    ivec2 i0 = min(ivec2(floor(x)), ivec2(u_field_preint_size - 2));
    vec2 f = x - vec2(i0);
    ivec2 row = ivec2(0, i * u_field_preint_size);
    vec4 a = mix(texelFetch(u_field_preint, row + i0, 0), texelFetch(u_field_preint, row + i0 + ivec2(1, 0), 0), f.x);
    vec4 b = mix(texelFetch(u_field_preint, row + i0 + ivec2(0, 1), 0),
                 texelFetch(u_field_preint, row + i0 + ivec2(1, 1), 0), f.x);
    return mix(a, b, f.y);
}

// x / (1 - exp(-x)), 1 at x = 0: what turns a member's segment colour back into its emission weight.
float depth_per_opacity(float tau) {
    return tau > 0.0 ? tau / opacity_of_depth(tau) : 1.0;
}

// Member i's segment of length len (associated colour, optical depth): its table entry by the end values,
// shortened, gradient opacity and shading at the midpoint p as for one field; an rgb member's colour the
// data's at p; a label member's segment its class at p over the whole segment (no values to pre-integrate).
vec4 field_segment(int i, float front, float back, float len, vec3 p, FieldTexels s, vec3 grad, vec3 dir) {
#ifdef FIELD_LABELS
    if (FIELD_ROLE[i] == 1) {
        vec4 cs = field_label_classify(i, p, dir);
        return vec4(cs.rgb * opacity_of_depth(cs.a * len), cs.a * len);
    }
#endif
    vec4 e = shorten(field_preintegrated(i, front, back), len / u_slab_length);
#ifdef GRADIENT_OPACITY
    e = shorten(e, min(1.0, length(grad) / u_gradient_reference));
#endif
#ifdef FIELD_RGB
    if (FIELD_ROLE[i] == 2) e.rgb = max(s.t[FIELD_GROUP[i]].rgb, 0.0) * opacity_of_depth(e.a);
#endif
#ifdef SHADING
    float alpha = opacity_of_depth(e.a);
    e.rgb = blinn_phong(alpha > 0.0 ? e.rgb / alpha : vec3(0.0), grad * u_field_epsilon_scale[i], dir) * alpha;
#endif
    return e;
}

// Member I's part of the mixture's segment (in preintegrated_segment(); FIELD_EACH as for classify()).
#define FIELD_MIX_SEGMENT(I) \
    if (field_inside(I, s)) { \
        vec4 e = field_segment(I, front.v[I], back.v[I], len, p, s, FIELD_GRADIENT_OF(I), dir); \
        weighted += e.rgb * depth_per_opacity(e.a); \
        tau += e.a; \
    }

// The mixture's segment of length len (associated colour, optical depth): each member's own table entry
// (C_i, tau_i), shortened, gradient opacity and shading at the midpoint p as for one field, for members
// whose box holds p; tau = sum tau_i, C = (1 - e^-tau) / tau sum_i C_i tau_i / (1 - e^-tau_i) (exact for
// constant fields).
vec4 preintegrated_segment(SegmentValue front, SegmentValue back, float len, vec3 p, vec3 dir) {
    FieldTexels s = field_texels(p);
#ifdef NEEDS_GRADIENT
    FieldGradients g = field_gradients(p);
#endif
    vec3 weighted = vec3(0.0);
    float tau = 0.0;
    FIELD_EACH(FIELD_MIX_SEGMENT)
    return vec4(weighted / depth_per_opacity(tau), tau);
}
#endif
