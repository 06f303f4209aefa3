// Conformance: vertex stage of the conf_rect* programs. Draws the rectangle pc.rect as two
// triangles (6 vertices, no vertex buffer) at depth pc.depth.x; vUv is (0,0) at (x0, y0).
#include "conf_rect_push.glsl"

layout(location = 0) out vec2 vUv;

void main() {
    const vec2 corners[6] = vec2[](vec2(0.0, 0.0), vec2(1.0, 0.0), vec2(0.0, 1.0),
                                   vec2(0.0, 1.0), vec2(1.0, 0.0), vec2(1.0, 1.0));
    vec2 c = corners[gl_VertexIndex % 6];
    vUv = c;
    gl_Position = vec4(mix(pc.rect.xy, pc.rect.zw, c), pc.depth.x, 1.0);
}
