#version 430
// A boundary face grown by u_margin pixels (grow.glsl), so that no pixel centre whose ray crosses
// the face is lost to the rasterizer's snapping: a ray through a face's edge, next to a face seen
// edge on at a crease of the boundary, lost its entry into the mesh that way (the oxygen post, the
// notched part seen along an axis).  The fragment keeps only rays crossing the face itself.  A face
// reaching behind a perspective eye's plane (w <= 0) goes out as it came, for GL to clip.
layout(triangles) in;
layout(triangle_strip, max_vertices = 6) out;

#include "grow.glsl"

uniform vec2 u_image_size;
uniform vec3 u_eye;      // centre-relative
uniform vec3 u_forward;

flat in uint v_cell[];
flat in vec3 v_normal[];
in vec3 v_position[];
flat out uint g_cell;
flat out vec3 g_normal;
flat out vec3 g_corner0, g_corner1, g_corner2;  // centre-relative

void face_out() {  // a geometry shader's outputs are undefined after each EmitVertex
    g_cell = v_cell[0];
    g_normal = v_normal[0];
    g_corner0 = v_position[0];
    g_corner1 = v_position[1];
    g_corner2 = v_position[2];
}

void emit(vec2 pixel) {
    face_out();
    gl_Position = vec4(pixel / u_image_size * 2.0 - 1.0, 0.0, 1.0);
    EmitVertex();
}

void main() {
    // A face every ray leaves by (its plane faces away from the eye, or from the view direction)
    // lists nothing: left out here, not fragment by fragment.  Faces within a rounding of edge on
    // go on, for their fragments to decide.
#ifdef CAMERA_ORTHOGRAPHIC
    vec3 to_face = u_forward;
#else
    vec3 to_face = v_position[0] - u_eye;
#endif
    float facing = dot(v_normal[0], to_face);
    if (facing > 1e-6 * length(v_normal[0]) * length(to_face)) return;
    vec4 c0 = gl_in[0].gl_Position, c1 = gl_in[1].gl_Position, c2 = gl_in[2].gl_Position;
    if (!(min(min(c0.w, c1.w), c2.w) > 0.0)) {
        face_out(); gl_Position = c0; EmitVertex();
        face_out(); gl_Position = c1; EmitVertex();
        face_out(); gl_Position = c2; EmitVertex();
        EndPrimitive();
        return;
    }
    vec2 q0 = (c0.xy / c0.w * 0.5 + 0.5) * u_image_size;  // pixels
    vec2 q1 = (c1.xy / c1.w * 0.5 + 0.5) * u_image_size;
    vec2 q2 = (c2.xy / c2.w * 0.5 + 0.5) * u_image_size;
    if (orient(q0, q1, q2) < 0.0) { vec2 t = q1; q1 = q2; q2 = t; }  // counter-clockwise
    // (a face seen exactly edge on grows into a thin strip; its fragments find n . d = 0 and go)
    vec2 n0 = outward(q0, q1), n1 = outward(q1, q2), n2 = outward(q2, q0);
    vec2 a0, b0, a1, b1, a2, b2;
    grow(q0, n2, n0, a0, b0);
    grow(q1, n0, n1, a1, b1);
    grow(q2, n1, n2, a2, b2);
    emit(a0); emit(b0); emit(b2); emit(a1); emit(a2); emit(b1);
    EndPrimitive();
}
