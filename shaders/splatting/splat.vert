#version 430 core
// One splat: a quad over the screen rectangle that holds every pixel whose ray meets the splat's
// kernel (an ellipsoid in world units: a sphere of radius u_radius voxels, scaled by the spacing).
// Four vertices a splat (a triangle strip), one instance per splat.

in vec4 in_splat;   // centre (world, relative to the box centre) and the value splatted (post, average)
#ifdef CLASSIFY_PRE
in vec4 in_optics;  // (sigma c, sigma) of the voxel: associated colour and extinction per world unit
#endif

uniform vec3 u_eye;
uniform vec3 u_forward;
uniform vec3 u_right;
uniform vec3 u_up;
uniform vec2 u_half_extent;
uniform vec2 u_image_size;
uniform float u_near;
uniform vec3 u_spacing;
uniform float u_radius;     // the kernel's support, voxels

flat out vec4 v_splat;
#ifdef CLASSIFY_PRE
flat out vec4 v_optics;
#endif

// The extremes of x / z over a sphere (centre x, z in view space, radius r, z > r): its tangents
// through the eye (Mara and McGuire 2013, "2D polyhedral bounds of a clipped, perspective-projected
// 3D sphere").
vec2 tangent_bounds(float x, float z, float r) {
    float w = sqrt(max(x * x + z * z - r * r, 0.0));
    float den = z * z - r * r;
    return vec2((x * z - r * w) / den, (x * z + r * w) / den);
}

void main() {
    vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1)) * 2.0 - 1.0;
    v_splat = in_splat;
#ifdef CLASSIFY_PRE
    v_optics = in_optics;
#endif
    vec3 p = in_splat.xyz - u_eye;
    // a half pixel of margin: the rasterizer's rounding must not drop a pixel whose ray grazes the support
    vec2 margin = 1.0 / u_image_size;
#ifdef CAMERA_ORTHOGRAPHIC
    vec2 centre = vec2(dot(p, u_right), dot(p, u_up)) / u_half_extent;
    // the ellipsoid's half-extent along a unit axis e: R |spacing * e|
    vec2 half_size = u_radius * vec2(length(u_spacing * u_right), length(u_spacing * u_up)) / u_half_extent;
    gl_Position = vec4(centre + corner * (half_size + margin), 0.0, 1.0);
#else
    float r = u_radius * max(max(u_spacing.x, u_spacing.y), u_spacing.z);  // the bounding sphere
    float z = dot(p, u_forward);
    if (z - r <= u_near) {
        gl_Position = vec4(corner, 0.0, 1.0);  // reaches the eye's plane: the whole image
        return;
    }
    vec2 bx = tangent_bounds(dot(p, u_right), z, r) / u_half_extent.x;
    vec2 by = tangent_bounds(dot(p, u_up), z, r) / u_half_extent.y;
    vec2 lo = vec2(bx.x, by.x) - margin, hi = vec2(bx.y, by.y) + margin;
    gl_Position = vec4(mix(lo, hi, corner * 0.5 + 0.5), 0.0, 1.0);
#endif
}
