#version 430 core
// One splat: a quad over the screen rectangle that holds every pixel whose ray meets the splat's
// kernel (an ellipsoid in world units: a sphere of radius u_radius voxels, scaled by the spacing).
// Four vertices a splat (a triangle strip), one instance per splat.

in vec4 in_splat;   // centre (world, relative to the box centre) and the value splatted (post, average)
#ifdef CLASSIFY_PRE
in vec4 in_optics;  // (sigma c, sigma) of the voxel: associated colour and extinction per world unit
#endif
#ifdef CULLING
in float in_core;   // 1: a core splat (post-classified culling, dvr_gl/renderers/splatting/splats.py)
#endif
#ifdef PARTICLES
in vec2 in_particle;  // an SPH particle's smoothing length h (world; support 2h) and weight m / rho
flat out vec4 v_particle;  // h, weight, 1 if smaller than a pixel (footprint averaged over pixels), 0
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
#ifdef SLABS
uniform vec2 u_slab;        // the slab's view depths: only the part of the support inside it is drawn
#endif
#ifdef LOW_PASS
// EWA's screen low-pass (dvr_gl/renderers/splatting/low_pass.py): the screen Gaussian (u_low_pass pixels)
// at the kernel's depth, added to the kernel's covariance across the view
uniform float u_low_pass;
uniform float u_sigma;      // the Gaussian's standard deviation, voxels
flat out mat3 v_metric;     // G = sigma^2 C^-1 (voxel units) and sqrt(det G)
flat out float v_metric_root;
#endif

flat out vec4 v_splat;
#ifdef CLASSIFY_PRE
flat out vec4 v_optics;
#endif
flat out float v_core;

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
#ifdef CULLING
    v_core = in_core;
#else
    v_core = 1.0;
#endif
    vec3 p = in_splat.xyz - u_eye;
    float z = dot(p, u_forward);
    vec2 xy = vec2(dot(p, u_right), dot(p, u_up));
#ifdef PARTICLES
    float r = 2.0 * in_particle.x;  // the support: a sphere
    v_particle = vec4(in_particle, 0.0, 0.0);
    // smaller than a pixel (support radius at its depth under SUBPIXEL_RADIUS pixels): its footprint is
    // averaged over the pixels it covers, whose squares the quad must reach (half a pixel more)
    float pixel_world = 2.0 * u_half_extent.y / u_image_size.y;
#ifndef CAMERA_ORTHOGRAPHIC
    pixel_world *= max(z, 0.0);
#endif
    if (z - r > u_near && r < SUBPIXEL_RADIUS * pixel_world) {
        v_particle.z = 1.0;
        vec2 ndc = xy / u_half_extent;
#ifndef CAMERA_ORTHOGRAPHIC
        ndc /= z;
#endif
        vec2 half_ndc = r / pixel_world * 2.0 / u_image_size + 2.0 / u_image_size;
        gl_Position = vec4(ndc + corner * half_ndc, 0.0, 1.0);
        return;
    }
#else
    float r = u_radius * max(max(u_spacing.x, u_spacing.y), u_spacing.z);  // the bounding sphere (world)
#ifdef LOW_PASS
    float pixel_world = 2.0 * u_half_extent.y / u_image_size.y;
#ifndef CAMERA_ORTHOGRAPHIC
    pixel_world *= max(z, 0.0);
#endif
    float s = u_low_pass * pixel_world;  // the screen Gaussian at the kernel's depth, world units
    vec3 a = u_right / u_spacing, b = u_up / u_spacing;
    float sigma2 = u_sigma * u_sigma;
    v_metric = sigma2 * inverse(mat3(sigma2) + s * s * (outerProduct(a, a) + outerProduct(b, b)));
    v_metric_root = sqrt(determinant(v_metric));
    // the world covariance grows by s^2 across the view: the support's extents across it grow by s in
    // units of sigma (widen2: its square); its depths stay
    float widen2 = s * s / sigma2;
#endif
#endif
    // the support's depths: all of it, or the part inside the slab (Mueller and Crawfis's kernel slice)
    float za = z - r, zb = z + r, section = r;
#ifdef KERNEL_BSPLINE
    float reach_z = 2.0 * dot(abs(u_spacing * u_forward), vec3(1.0));  // the cube's depth half-extent
    za = z - reach_z;
    zb = z + reach_z;
#endif
#ifdef SLABS
    za = max(za, u_slab.x);
    zb = min(zb, u_slab.y);
    if (za >= zb) {
        gl_Position = vec4(2.0, 2.0, 0.0, 1.0);  // misses the slab: a point off the image, no fragment
        return;
    }
    float gap = max(max(u_slab.x - z, z - u_slab.y), 0.0);
    section = sqrt(max(r * r - gap * gap, 0.0));   // the widest cross-section inside the slab
#endif
#ifdef LOW_PASS
    // the widened support lies within the Minkowski sum of the kernel's and a disk of u_radius sqrt(widen2)
    // across the view (support functions of a sum of covariances: sqrt(x + y) <= sqrt x + sqrt y)
    float disk = u_radius * sqrt(widen2);
    section += disk;
    r = sqrt(r * r + disk * disk);  // its bounding sphere: the covariance is at most r^2 + disk^2 in any direction
#endif
    // a half pixel of margin: the rasterizer's rounding must not drop a pixel whose ray grazes the support
    vec2 margin = 1.0 / u_image_size;
#ifdef CAMERA_ORTHOGRAPHIC
    // the ellipsoid's half-extent along a unit axis e: R |spacing * e|; no more than the section
#ifdef PARTICLES
    vec2 half_size = vec2(section);
#elif defined(KERNEL_BSPLINE)
    // the cube of four voxels' half-extent along a unit axis e: 2 sum |spacing_i e_i|
    vec2 half_size = min(2.0 * vec2(dot(abs(u_spacing * u_right), vec3(1.0)), dot(abs(u_spacing * u_up), vec3(1.0))),
                         vec2(section));
#elif defined(LOW_PASS)
    vec2 half_size = min(u_radius * sqrt(vec2(dot(u_spacing * u_right, u_spacing * u_right),
                                              dot(u_spacing * u_up, u_spacing * u_up)) + widen2), vec2(section));
#else
    vec2 half_size = min(u_radius * vec2(length(u_spacing * u_right), length(u_spacing * u_up)), vec2(section));
#endif
    gl_Position = vec4(xy / u_half_extent + corner * (half_size / u_half_extent + margin), 0.0, 1.0);
#else
    if (za <= u_near) {
        gl_Position = vec4(corner, 0.0, 1.0);  // reaches the eye's plane: the whole image
        return;
    }
    // the cylinder of the section between za and zb (x / z is extreme at one of its end disks) and,
    // where the whole sphere lies in front of the eye, its tangents: both bounds hold, the smaller is kept
    vec2 lo = min((xy - section) / za, (xy - section) / zb);
    vec2 hi = max((xy + section) / za, (xy + section) / zb);
    if (z - r > u_near) {
        vec2 bx = tangent_bounds(xy.x, z, r), by = tangent_bounds(xy.y, z, r);
        lo = max(lo, vec2(bx.x, by.x));
        hi = min(hi, vec2(bx.y, by.y));
    }
    lo = lo / u_half_extent - margin;
    hi = hi / u_half_extent + margin;
    gl_Position = vec4(mix(lo, hi, corner * 0.5 + 0.5), 0.0, 1.0);
#endif
}
