#version 330 core
// The simplest ray caster that does the work of raycast.frag's emission-only program
// (perspective ray, box clip, front-to-back emission-absorption with hardware trilinear
// filtering and a table lookup), written out by hand with no includes, options or defines.
// Only `dvr bench raycast` uses it, to show that specialization costs nothing.

uniform vec3 u_eye, u_forward, u_right, u_up;
uniform vec2 u_half_extent, u_image_size;
uniform vec3 u_box_lo, u_box_hi;
uniform vec3 u_world_to_voxel_scale, u_world_to_voxel_offset;
uniform ivec3 u_dims;
uniform float u_value_scale, u_value_offset, u_sample_distance;
uniform sampler3D u_volume;
uniform sampler2D u_lut;
uniform int u_lut_size;
uniform float u_lut_lo, u_lut_scale;
out vec4 frag_color;

void main() {
    vec2 ndc = gl_FragCoord.xy / u_image_size * 2.0 - 1.0;
    vec3 d = normalize(u_forward + ndc.x * u_half_extent.x * u_right + ndc.y * u_half_extent.y * u_up);
    vec3 inv = 1.0 / d;
    vec3 ta = (u_box_lo - u_eye) * inv, tb = (u_box_hi - u_eye) * inv;
    vec3 tmin = min(ta, tb), tmax = max(ta, tb);
    float t0 = max(max(max(tmin.x, tmin.y), tmin.z), 0.0);
    float t1 = min(min(tmax.x, tmax.y), tmax.z);
    frag_color = vec4(0.0);
    if (t1 <= t0) return;
    int n = max(int(ceil((t1 - t0) / u_sample_distance)), 1);
    vec3 colour = vec3(0.0);
    float depth = 0.0;
    for (int k = 0; k < n; ++k) {
        float start = t0 + float(k) * u_sample_distance;
        float len = min(u_sample_distance, t1 - start);
        vec3 u = (u_eye + (start + 0.5 * len) * d) * u_world_to_voxel_scale + u_world_to_voxel_offset;
        float v = texture(u_volume, (clamp(u, vec3(0.0), vec3(u_dims - 1)) + 0.5) / vec3(u_dims)).r
                  * u_value_scale + u_value_offset;
        float x = clamp((v - u_lut_lo) * u_lut_scale, 0.0, float(u_lut_size - 1));
        int i0 = min(int(floor(x)), u_lut_size - 2);
        vec4 tf = mix(texelFetch(u_lut, ivec2(i0, 0), 0), texelFetch(u_lut, ivec2(i0 + 1, 0), 0), x - float(i0));
        float tau = tf.a * len;
        colour += exp(-depth) * (1.0 - exp(-tau)) * tf.rgb;
        depth += tau;
    }
    frag_color = vec4(colour, 1.0 - exp(-depth));
}
