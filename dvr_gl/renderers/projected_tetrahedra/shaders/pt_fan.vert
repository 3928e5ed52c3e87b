#version 430
// Projected tetrahedra, Shirley and Tuchman's fan built on the host (fan.py, fan_compiled.py): each
// vertex its pixel (GL window coordinates), colour and optical depth, and the cell's thick vertex's
// optical depth; pt_st.frag turns the interpolated pair into opacity, as after pt.geom's fan.
in vec2 in_pixel;
in vec4 in_st;         // colour, optical depth
in float in_tau_max;   // the thick vertex's optical depth

uniform vec2 u_image_size;

noperspective out vec4 g_st;
flat out float g_tau_max;

void main() {
    g_st = in_st;
    g_tau_max = in_tau_max;
    gl_Position = vec4(in_pixel / u_image_size * 2.0 - 1.0, 0.0, 1.0);
}
