#version 330 core
// Samples a label map at the world points of u_points (one a pixel) with labels.glsl: writes (label,
// indicator gradient) or, with PROBE_CLASS, the label's (r, g, b, sigma) from its table.
#include "common/labels.glsl"

uniform sampler3D u_labels;
uniform sampler2D u_points;      // W x H, RGBA32F: a world point per pixel
uniform sampler2D u_label_table;
uniform ivec3 u_label_layout;
uniform int u_channel;
uniform float u_value_scale;
uniform float u_value_offset;
uniform ivec3 u_dims;
uniform vec3 u_scale;
uniform vec3 u_offset;
out vec4 frag;

void main() {
    vec3 p = texelFetch(u_points, ivec2(gl_FragCoord.xy), 0).xyz;
    LabelGrid g = label_grid(u_channel, u_value_scale, u_value_offset, u_dims, u_scale, u_offset);
    vec3 gradient;
    int label = label_sample(u_labels, g, p, gradient);
#ifdef PROBE_CLASS
    frag = label_class(u_label_table, u_label_layout, label);
#else
    frag = vec4(float(label), gradient);
#endif
}
