"""The rain streaks' GLSL (`rain.py` draws them around the eye): built with `program.program`,
a streak takes the sky's colours and the surfaces' tone mapping.
"""

RAIN_VS = """
uniform mat4 p3d_ViewProjectionMatrix;
uniform mat4 p3d_ViewMatrixInverse;
uniform vec3 rain_box;    // [m] the streaks fill this box around the eye
uniform vec4 rain_fall;   // xyz travelled by a drop since t = 0 [m], w share of drops shown
uniform vec3 rain_step;   // [m] a streak's length and direction (the drop's motion blur)
in vec4 p3d_Vertex;       // a drop's place in the unit box
in vec4 p3d_Color;        // r: the drop's rank (shown when < rain_fall.w), g: 0 head, 1 tail
out float v_alpha;

void main() {
    vec3 eye = p3d_ViewMatrixInverse[3].xyz;
    vec3 p = p3d_Vertex.xyz * rain_box + rain_fall.xyz;
    p = eye + (fract((p - eye) / rain_box + 0.5) - 0.5) * rain_box;  // wrap around the eye
    p += rain_step * p3d_Color.g;
    v_alpha = step(p3d_Color.r, rain_fall.w) * (1.0 - 0.7 * p3d_Color.g);
    gl_Position = p3d_ViewProjectionMatrix * vec4(p, 1.0);
}
"""

RAIN_FS = """
in float v_alpha;
out vec4 frag;
void main() {
    // a drop shows the world around it squeezed (bright sky, dark ground): about its mean
    vec3 c = sky_horizon * 0.55 + sky_ambient * 0.25;
    frag = vec4(to_display(tone_map(c)), RAIN_ALPHA * v_alpha);
}
"""
