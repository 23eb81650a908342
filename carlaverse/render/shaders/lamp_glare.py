"""The glare of a lit headlamp seen from the front (`headlights.py` draws the sprites): built
with `program.program`, it fades in the surfaces' fog and wears the beam's colour.
"""

GLARE_VS = """
uniform mat4 p3d_ModelViewProjectionMatrix;
uniform mat4 p3d_ModelMatrix;
in vec4 p3d_Vertex;
in vec4 p3d_Color;
in vec2 p3d_MultiTexCoord0;
out vec2 v_uv;
out vec3 v_pos;
out float v_level;
void main() {
    gl_Position = p3d_ModelViewProjectionMatrix * p3d_Vertex;
    v_pos = (p3d_ModelMatrix * p3d_Vertex).xyz;
    v_uv = p3d_MultiTexCoord0;
    v_level = p3d_Color.r;
}
"""

GLARE_FS = """
uniform mat4 p3d_ViewMatrixInverse;
in vec2 v_uv;
in vec3 v_pos;
in float v_level;
out vec4 frag;
void main() {
    float r2 = dot(v_uv - 0.5, v_uv - 0.5) * 4.0;
    float glow = exp(-r2 * 9.0) + 0.25 * exp(-r2 * 2.5);
    float through = exp(-fog.a * length(p3d_ViewMatrixInverse[3].xyz - v_pos));
    frag = vec4(HEAD_RGB * (glow * v_level * through), 1.0);  // added to what lies behind
}
"""
