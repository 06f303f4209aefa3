// Test program for the field atlas sampling code (renderer/shaders/sdf_field.glsl): one invocation
// per point, each point naming its field's slot; writes the distance, the interpolation bound and
// the voxel size.
#version 450
layout(local_size_x = 64) in;

#define SDF_FIELDS_SET 0
#define SDF_FIELDS_BINDING 0
#define SDF_ATLAS_BINDING 1
#include "sdf_field.glsl"

struct FieldPoint {
    vec3 p;     // field space
    uint slot;  // index into sdfFields
};

layout(set = 0, binding = 2, std430) readonly buffer FieldPoints { FieldPoint points[]; };
layout(set = 0, binding = 3, std430) writeonly buffer FieldResults { vec4 results[]; };

layout(push_constant) uniform FieldPush { uvec4 count; } pc;  // x: number of points

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count.x) return;
    FieldPoint e = points[i];
    results[i] = vec4(sdfFieldDistance(e.slot, e.p), sdfFieldInterpolationBound(e.slot, e.p),
                      sdfFieldVoxelSize(e.slot), 0.0);
}
