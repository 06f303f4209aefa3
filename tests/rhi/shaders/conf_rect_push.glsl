// Conformance: push constants shared by the vertex and fragment stages of the conf_rect* programs
// (must match penumbra::conformance::RectPush).
layout(push_constant) uniform RectPush {
    vec4 rect;   // x0, y0, x1, y1 in NDC
    vec4 color;  // fragment colour
    vec4 depth;  // x: clip-space z, y: fragment depth offset, z: extra value
} pc;
