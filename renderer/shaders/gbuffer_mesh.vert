// gbuffer_mesh, vertex stage: one draw per MeshRenderer; the object's matrices come from the
// scene's objects buffer, indexed by a push constant.
#version 450
#pragma penumbra_variants ALBEDO
#include "scene.glsl"

SCENE_OBJECTS;
layout(push_constant) uniform Draw {
    uvec4 object;  // x index into objects[]
} draw;

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;

layout(location = 0) out vec3 vNormal;
layout(location = 1) out float vViewDepth;
layout(location = 2) out vec4 vClip;
layout(location = 3) out vec4 vPrevClip;
layout(location = 4) out vec2 vUv;
layout(location = 5) flat out uint vMaterial;
layout(location = 6) flat out uint vEntity;

void main() {
    Object o = objects[draw.object.x];
    vec4 world = o.model * vec4(inPosition, 1.0);
    vec4 prevWorld = o.prevModel * vec4(inPosition, 1.0);
    vNormal = mat3(o.normalMatrix) * inNormal;
    // Linear depth is affine in world space, so perspective-correct interpolation keeps it exact.
    vViewDepth = dot(world.xyz - view.position.xyz, view.forward.xyz);
    vClip = view.viewProj * world;
    vPrevClip = view.prevViewProj * prevWorld;
    vUv = inUv;
    vMaterial = o.info.x;
    vEntity = o.info.y;
    gl_Position = vClip;
}
