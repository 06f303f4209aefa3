// Camera and frame constants of the RHI demo frame (set 0, binding 0 in every demo program).
layout(set = 0, binding = 0) uniform Camera {
    mat4 viewProj;
    mat4 invViewProj;
    vec4 position;    // xyz camera position
    vec4 forward;     // xyz unit view direction
    vec4 lightDir;    // xyz unit direction towards the light, w light intensity
    vec4 projParams;  // x = proj[2][2], y = proj[3][2] (view depth -> NDC depth), z = near, w = far
    ivec4 counts;     // x primitive count, y width, z height
} cam;
