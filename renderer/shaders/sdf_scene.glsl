// The SDF objects of a frame as the shaders see them (renderer/features/sdf_scene.h holds the C++
// side): one SdfObject per traced entity, the shape-program records they point into, and (variant
// SDF_FIELDS) the field atlas. The same distance code serves the trace, the debug views and, later,
// shadows and AO.
//
// Use: define SDF_SCENE_SET, SDF_OBJECTS_BINDING and SHAPE_RECORDS_BINDING (and with SDF_FIELDS
// also SDF_FIELDS_BINDING and SDF_ATLAS_BINDING), then include this file. SDF_OBJECTS_UBO reads
// the objects from a uniform block instead of a storage buffer.
//
// Distances are conservative: an object's world distance is its local (field or program) distance
// times the smallest singular value of its model matrix's 3x3 part (boundsMin.w), which is exact
// for rotation, translation and uniform scale and never an overestimate under non-uniform scale
// (the image of a local ball of radius r contains the world ball of radius sigma_min * r). Field
// distances subtract fieldSafety times the trilinear interpolation bound (sdf_field.glsl), so with
// fieldSafety = 1 a traced ray never steps through the surface of the baked mesh.
#ifndef PENUMBRA_SDF_SCENE_GLSL
#define PENUMBRA_SDF_SCENE_GLSL

struct SdfObject {
    mat4 worldToLocal;  // inverse of model
    mat4 model;         // local (program / field space) -> world
    mat4 prevModel;     // the previous frame's model matrix (velocity)
    vec4 boundsMin;     // xyz local bounds of the solid (+-1e30 when unbounded), w sigma_min of model
    vec4 boundsMax;     // xyz local bounds, w unused
    uvec4 info;         // x kind (SDF_KIND_*), y first record (shapes) / atlas slot (field),
                        // z material index, w entity index
    uvec4 params;       // x this object's step limit (0: the pass setting)
};

const uint SDF_KIND_SHAPES = 0u;
const uint SDF_KIND_FIELD = 1u;

#ifdef SDF_OBJECTS_UBO
// The objects as a uniform block of kSdfObjectsUniformCapacity (renderer/features/sdf_scene.h)
// records, bound over the frame's objects only (sdfObjectsUniformBytes): a CPU device (llvmpipe) loads
// a storage buffer lane by lane in a loop, a uniform block with one gather per component, and the
// trace's candidate loop reads an object's transform and bounds at every step.
layout(set = SDF_SCENE_SET, binding = SDF_OBJECTS_BINDING, std140) uniform SdfObjectsUniform {
    SdfObject sdfObjects[256];
};
#else
layout(set = SDF_SCENE_SET, binding = SDF_OBJECTS_BINDING, std430) readonly buffer SdfObjects {
    SdfObject sdfObjects[];
};
#endif

#define SHAPE_RECORDS_SET SDF_SCENE_SET
#include "shape_program.glsl"

#ifdef SDF_FIELDS
#define SDF_FIELDS_SET SDF_SCENE_SET
#include "sdf_field.glsl"
#endif

vec3 sdfToLocal(uint object, vec3 world) { return (sdfObjects[object].worldToLocal * vec4(world, 1.0)).xyz; }

// World-space lower bound of the distance from a point (local position pl) to the object's solid:
// the distance to its local bounds box, scaled; 0 inside the box.
float sdfBoxDistance(uint object, vec3 pl) {
    vec3 q = max(sdfObjects[object].boundsMin.xyz - pl, pl - sdfObjects[object].boundsMax.xyz);
    return length(max(q, vec3(0.0))) * sdfObjects[object].boundsMin.w;
}

// Signed distance of a shape object (info: its SdfObject::info) in local units at local position pl.
float sdfShapeDistance(uvec4 info, vec3 pl) {
#ifdef SHAPE_PRIMITIVES
    // Every shape object of the frame is one shape (SdfSceneBuffers::shapePrimitives).
    return evalShapePrimitive(info.y, pl);
#else
    return evalShapeProgram(info.y, pl);
#endif
}

// Signed distance in the object's local units at local position pl.
float sdfLocalDistance(uint object, vec3 pl, float fieldSafety) {
    uvec4 info = sdfObjects[object].info;
    if (info.x == SDF_KIND_SHAPES) return sdfShapeDistance(info, pl);
#ifdef SDF_FIELDS
    SdfField f = sdfFields[info.y];  // the slot's record loaded once for both
    return sdfFieldDistanceOf(f, pl) - fieldSafety * sdfFieldInterpolationBoundOf(f, pl);
#else
    return SHAPE_FAR;
#endif
}

// Conservative signed world distance of one object at world position pw.
float sdfObjectDistance(uint object, vec3 pw, float fieldSafety) {
    return sdfObjects[object].boundsMin.w * sdfLocalDistance(object, sdfToLocal(object, pw), fieldSafety);
}

// The unit gradient of the object's world distance at p by central differences over a tetrahedron
// of offsets h (4 evaluations, fields without their safety bound): the hit's normal of the trace,
// the box trace and the reflections. The object's record, transform and field slot are loaded once
// for the four points (each is sdfObjectDistance(obj, p + k h, 0)).
vec3 sdfObjectNormal(uint obj, vec3 p, float h) {
    uvec4 info = sdfObjects[obj].info;
    mat4 w = sdfObjects[obj].worldToLocal;
    float scale = sdfObjects[obj].boundsMin.w;
#ifdef SDF_FIELDS
    SdfField f = sdfFields[info.x == SDF_KIND_FIELD ? info.y : 0u];
#endif
    vec3 g = vec3(0.0);
    for (int i = 0; i < 4; ++i) {
        vec3 k = vec3((i == 0 || i == 3) ? 1.0 : -1.0, (i == 2 || i == 3) ? 1.0 : -1.0,
                      (i == 1 || i == 3) ? 1.0 : -1.0);
        vec3 pl = (w * vec4(p + k * h, 1.0)).xyz;
        float d;
#ifdef SDF_FIELDS
        if (info.x == SDF_KIND_SHAPES) d = sdfShapeDistance(info, pl);
        else d = sdfFieldDistanceOf(f, pl);
#else
        d = info.x == SDF_KIND_SHAPES ? sdfShapeDistance(info, pl) : SHAPE_FAR;
#endif
        g += k * (scale * d);
    }
    return normalize(g);
}

// The object's voxel size in world units (0 for analytic shapes).
float sdfObjectVoxel(uint object) {
#ifdef SDF_FIELDS
    uvec4 info = sdfObjects[object].info;
    if (info.x == SDF_KIND_FIELD) return sdfFieldVoxelSize(info.y) * sdfObjects[object].boundsMin.w;
#endif
    return 0.0;
}

// The world ray o + t d (d unit) against the object's local bounds box: [enter, exit] in t, empty
// (enter > exit) when the ray misses it. Affine maps keep the ray parameter, so the local ray is
// (W o) + t (W d) with the same t.
vec2 sdfRayInterval(uint object, vec3 o, vec3 d) {
    mat4 w = sdfObjects[object].worldToLocal;
    vec3 lo = (w * vec4(o, 1.0)).xyz;
    vec3 ld = mat3(w) * d;
    vec3 inv = 1.0 / mix(ld, vec3(1e-30), lessThan(abs(ld), vec3(1e-30)));
    vec3 t0 = (sdfObjects[object].boundsMin.xyz - lo) * inv;
    vec3 t1 = (sdfObjects[object].boundsMax.xyz - lo) * inv;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    return vec2(max(max(tn.x, tn.y), tn.z), min(min(tf.x, tf.y), tf.z));
}

#endif
