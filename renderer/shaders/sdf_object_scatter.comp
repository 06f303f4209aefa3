// sdf_object_scatter: writes the SDF objects that changed this frame into the persistent object
// array (renderer/features/sdf_scene.h, SdfSceneStore). The delta buffer holds one entry per
// changed object: a uvec4 whose x is the object's index in the array, then the object's 256-byte
// GpuSdfObject record as 16 uvec4. One invocation copies one uvec4 of one record, bit for bit
// (uints: no float conversion can touch NaN payloads or denormals). The layout of the record is
// not interpreted here, so the trace's SdfObject struct may change without this shader.
#version 450
layout(local_size_x = 64) in;

layout(set = 2, binding = 0, std430) readonly buffer SdfObjectDeltas { uvec4 sdfObjectDeltas[]; };
layout(set = 2, binding = 1, std430) writeonly buffer SdfObjectWords { uvec4 sdfObjectWords[]; };

layout(push_constant) uniform SdfObjectScatter {
    uvec4 range;  // x first entry of this dispatch, y entries in the delta buffer
} scatter;

const uint kRecordWords = 16u;  // uvec4 per GpuSdfObject
const uint kEntryWords = 17u;   // the index header + the record

void main() {
    uint word = gl_GlobalInvocationID.x % kRecordWords;
    uint entry = scatter.range.x + gl_GlobalInvocationID.x / kRecordWords;
    if (entry >= scatter.range.y) return;
    uint target = sdfObjectDeltas[entry * kEntryWords].x;
    sdfObjectWords[target * kRecordWords + word] = sdfObjectDeltas[entry * kEntryWords + 1u + word];
}
