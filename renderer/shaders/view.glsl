// The shared per-view / per-frame uniform block: set 0, binding 0 in every program that includes
// this file. penumbra-shaderc emits its C++ struct once (penumbra::shaders::View in the generated
// <shaders/view.h>) and rejects any program that declares a block named View with another layout
// or at another set/binding (tools/shaderc/README.md).
// Conventions: world space is right-handed; clip space is Vulkan's (y down, depth 0..1; the GL
// backend matches it with glClipControl); pixel coordinates have y down from the top row.
#ifndef PENUMBRA_VIEW_GLSL
#define PENUMBRA_VIEW_GLSL

layout(set = 0, binding = 0, std140) uniform View {
    mat4 viewMatrix;    // world -> view
    mat4 projMatrix;    // view -> clip, including this frame's jitter
    mat4 viewProj;      // world -> clip (projMatrix * viewMatrix)
    mat4 invViewProj;   // clip -> world
    mat4 prevViewProj;  // the previous frame's viewProj (velocity, reprojection)
    vec4 position;      // xyz camera position in world space
    vec4 forward;       // xyz unit view direction (linear depth = distance along it)
    vec4 rayRight;      // xyz camera right / proj[0][0]: ray = forward + ndc.x * rayRight + ndc.y * rayUp
    vec4 rayUp;         // xyz camera up / proj[1][1] (negative y scale: NDC y = -1 is row 0)
    vec4 viewport;      // width, height, 1 / width, 1 / height in pixels
    vec4 jitter;        // xy this frame's sub-pixel projection jitter in pixels, zw the previous frame's
    float time;         // seconds since the first frame
    float deltaTime;    // seconds since the previous frame
    uint frameIndex;    // frames since the first frame (0-based)
} view;

#endif
