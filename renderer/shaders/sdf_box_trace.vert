// sdf_box_trace, vertex stage (renderer/features/sdf_box_trace.h): one draw per traced SDF object.
// draw.y 0: the 12 triangles of the object's local bounds box, wound counter-clockwise seen from
// outside in the object's frame (a mirroring model swaps each triangle's last two corners, so the
// pipeline's back-face culling keeps the faces towards the camera); the C++ side draws a box this
// way only when every corner lies beyond the near plane. draw.y 1: a full-screen triangle on the
// near plane (depth 0) for a box that contains the camera, crosses the near plane or is unbounded;
// the fragment clips it to the box by ray-box intersection. Either way the rasterized depth is never
// behind the traced hit, which the fragment's depth_greater declaration promises.
#version 450
#include "scene.glsl"

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 0
#define SHAPE_RECORDS_BINDING 1
#define SDF_FIELDS_BINDING 2
#define SDF_ATLAS_BINDING 3
#include "sdf_scene.glsl"

layout(push_constant) uniform SdfBoxTrace {
    uvec4 counts;   // as sdf_trace.comp's (x objects, z step limit, w refine steps)
    vec4 epsilons;  // as sdf_trace.comp's
    vec4 clip;      // as sdf_trace.comp's
    uvec4 accel;    // as sdf_trace.comp's (culling: the per-pixel list is this draw's object)
    uvec4 draw;     // x object, y 1 = a near-plane triangle instead of the box
} trace;

// Corner c of the box: bit 0 x, bit 1 y, bit 2 z (0 min, 1 max).
const uint kBoxCorners[36] = uint[](4u, 6u, 2u, 4u, 2u, 0u, 1u, 3u, 7u, 1u, 7u, 5u, 1u, 5u, 4u, 1u, 4u, 0u,
                                    2u, 6u, 7u, 2u, 7u, 3u, 2u, 3u, 1u, 2u, 1u, 0u, 4u, 5u, 7u, 4u, 7u, 6u);

void main() {
    uint obj = trace.draw.x;
    if (trace.draw.y != 0u) {
        // Corners 0, 2, 1 of fullscreen.glsl's triangle: front-facing under the box's winding rule.
        int v = gl_VertexIndex == 0 ? 0 : 3 - gl_VertexIndex;
        vec2 uv = vec2((v << 1) & 2, v & 2);
        gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
        return;
    }
    mat4 model = sdfObjects[obj].model;
    int i = gl_VertexIndex;
    if (determinant(mat3(model)) < 0.0) i += i % 3 == 1 ? 1 : (i % 3 == 2 ? -1 : 0);
    uint c = kBoxCorners[i];
    vec3 local = mix(sdfObjects[obj].boundsMin.xyz, sdfObjects[obj].boundsMax.xyz,
                     vec3(float(c & 1u), float((c >> 1u) & 1u), float((c >> 2u) & 1u)));
    gl_Position = view.viewProj * (model * vec4(local, 1.0));
}
