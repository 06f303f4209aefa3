// Test program for the per-object distance code (renderer/shaders/sdf_scene.glsl, variant
// SDF_FIELDS, bound as sdf_trace.comp binds it: objects, shape records, field slots and the atlas in
// one set): one invocation per (object, world point); writes sdfObjectDistance with fieldSafety 1 and
// 0, sdfObjectVoxel and sdfBoxDistance at the point.
#version 450
layout(local_size_x = 64) in;

#define SDF_FIELDS
#define SDF_SCENE_SET 0
#define SDF_OBJECTS_BINDING 0
#define SHAPE_RECORDS_BINDING 1
#define SDF_FIELDS_BINDING 2
#define SDF_ATLAS_BINDING 3
#include "sdf_scene.glsl"

struct ObjectPoint {
    vec3 p;       // world space
    uint object;  // index into sdfObjects
};

layout(set = 0, binding = 4, std430) readonly buffer ObjectPoints { ObjectPoint points[]; };
layout(set = 0, binding = 5, std430) writeonly buffer ObjectResults { vec4 results[]; };

layout(push_constant) uniform ObjectPush { uvec4 count; } pc;  // x: number of points

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count.x) return;
    ObjectPoint e = points[i];
    results[i] = vec4(sdfObjectDistance(e.object, e.p, 1.0), sdfObjectDistance(e.object, e.p, 0.0),
                      sdfObjectVoxel(e.object), sdfBoxDistance(e.object, sdfToLocal(e.object, e.p)));
}
