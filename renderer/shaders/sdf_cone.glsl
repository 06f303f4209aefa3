// Cone-traced visibility through the frame's SDF objects (owned by the sdf_shadow module,
// renderer/features/sdf_shadow.h; also used by sdf_reflection to shadow reflected hits). After
// Wright's distance-field area shadows (reference 001) and mTec 8.2.5 (reference 000), with the
// penumbra from the light's actual size instead of a free sharpness constant.
//
// Use: include after sdf_scene.glsl (which declares sdfObjects and the distance code).
//
// STABLE INTERFACE (other modules call these; change only together with them):
//
//   float sdfConeVisibility(vec3 origin, vec3 dir, float tMin, float tMax, float sinHalfAngle,
//                           uint objectCount, uint maxSteps, float fieldSafety, float epsilon);
//       The visible fraction in [0, 1] of a light seen from `origin` in unit direction `dir` under
//       the cone half-angle asin(sinHalfAngle), marching t in [tMin, tMax] over the objects
//       [0, objectCount) whose params.y has SDF_OBJECT_CASTS_SHADOWS. sinHalfAngle <= 0 is a hard
//       (binary) shadow ray: 0 as soon as the conservative distance drops below `epsilon` (world
//       units; also the smallest step). maxSteps bounds the distance evaluations. fieldSafety as in
//       sdf_scene.glsl (EffectsDesc::trace.fieldSafety).
//
//   float sdfSurfaceBias(vec3 p, float pixelSize, uint objectCount);
//       The offset along the surface normal (world units) that keeps a ray leaving the surface at p
//       from shadowing itself on the surface's own distance error: a quarter pixel footprint
//       (pixelSize = the pixel's world size at p; analytic surfaces are traced to a small fraction
//       of that) and at least 1.5 voxels of the nearest field object (its trilinear surface lies up
//       to a voxel off the baked one, and the safe distance another interpolation bound below
//       that). Start the ray at p + n * bias with tMin = 2 * pixelSize + bias along the light
//       direction: the normal offset moves the shadow sideways by bias * tan(angle of incidence),
//       so it stays small; the start along the ray, which moves nothing, clears the rest.
//
//   float sdfDiscVisible(float x);
//       The visible fraction of a uniform disc of radius 1 cut by a straight edge at signed offset
//       x from its centre (x >= 1 all visible, x <= -1 none).
//
// The estimate. At a march point o + t dir the cone's cross-section is a disc whose edge is
// t sin(halfAngle) from the axis point (the distance from the axis point to the cone's surface);
// the nearest occluder surface is d away (conservative SDF distance, negative inside). Taking the
// occluder locally as a half-space whose boundary is d from the axis, the fraction of the light
// disc it leaves visible is sdfDiscVisible(x) with x = d / (t sin(halfAngle)): the area of a
// circular segment, 0.5 + (x sqrt(1 - x^2) + asin(x)) / pi, i.e. the light is treated as a
// uniform disc of directions (a sphere or sun disc of uniform radiance). The most occluded point
// along the ray (the minimum x) decides the visibility. Only the light's size enters: no tuning
// constant. Known bias: an occluder whose angular size is close to the light's has a curved edge
// across the disc, and the half-space covers more of the disc than it does (the estimate is then
// darker than the exact cap overlap; tests/renderer/sdf_shadow_test.cpp measures it). Inside an
// occluder the distance is that to the nearest face, not to the silhouette edge seen from the
// receiver, so an occluder thinner than the cone's cross-section where the ray crosses it lets
// about half the light through (x >= -thickness / (2 t sin(halfAngle))): thin plates give weak
// umbras, as in every distance-field cone trace.
//
// Culling: an object takes part in a ray only if its bounds box, grown by the cone's radius where
// the cone could reach it, meets the ray in [tMin, tMax]; up to SDF_CONE_LIST objects are kept in
// a list, a ray meeting more boxes marches over all objects (correct, slower).
#ifndef PENUMBRA_SDF_CONE_GLSL
#define PENUMBRA_SDF_CONE_GLSL

const uint SDF_OBJECT_CASTS_SHADOWS = 1u;  // GpuSdfObject::params.y (kSdfObjectCastsShadows)
const int SDF_CONE_LIST = 16;

float sdfDiscVisible(float x) {
    x = clamp(x, -1.0, 1.0);
    return clamp(0.5 + (x * sqrt(1.0 - x * x) + asin(x)) / 3.14159265358979, 0.0, 1.0);
}

bool sdfConeUnbounded(uint obj) { return sdfObjects[obj].boundsMax.x >= 1.0e29 || sdfObjects[obj].boundsMin.x <= -1.0e29; }

// The ray o + t d against the object's local box grown by `grow` world units: [enter, exit].
// World distance >= sigma_min * local distance, so growing the local box by grow / sigma_min covers
// every point within `grow` of the world box.
vec2 sdfConeInterval(uint obj, vec3 o, vec3 d, float grow) {
    if (sdfConeUnbounded(obj)) return vec2(-3.0e38, 3.0e38);
    float g = grow / max(sdfObjects[obj].boundsMin.w, 1e-30);
    mat4 w = sdfObjects[obj].worldToLocal;
    vec3 lo = (w * vec4(o, 1.0)).xyz;
    vec3 ld = mat3(w) * d;
    vec3 inv = 1.0 / mix(ld, vec3(1e-30), lessThan(abs(ld), vec3(1e-30)));
    vec3 t0 = (sdfObjects[obj].boundsMin.xyz - g - lo) * inv;
    vec3 t1 = (sdfObjects[obj].boundsMax.xyz + g - lo) * inv;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    return vec2(max(max(tn.x, tn.y), tn.z), min(min(tf.x, tf.y), tf.z));
}

// Farthest distance from o to the object's world box (bounding sphere of the local box through the
// model matrix; the Frobenius norm bounds the largest singular value).
float sdfConeFarthest(uint obj, vec3 o) {
    mat4 m = sdfObjects[obj].model;
    vec3 lc = 0.5 * (sdfObjects[obj].boundsMin.xyz + sdfObjects[obj].boundsMax.xyz);
    vec3 lh = 0.5 * (sdfObjects[obj].boundsMax.xyz - sdfObjects[obj].boundsMin.xyz);
    float scale = sqrt(dot(m[0].xyz, m[0].xyz) + dot(m[1].xyz, m[1].xyz) + dot(m[2].xyz, m[2].xyz));
    return length((m * vec4(lc, 1.0)).xyz - o) + length(lh) * scale;
}

uint g_coneList[SDF_CONE_LIST];
vec2 g_coneInterval[SDF_CONE_LIST];
int g_coneCount;
bool g_coneOverflow;

// Fills the list of objects the cone can meet; returns false when none can.
bool sdfConeCull(vec3 o, vec3 d, float tMin, float tMax, float tanHalf, float epsilon, uint objectCount) {
    g_coneCount = 0;
    g_coneOverflow = false;
    for (uint obj = 0u; obj < objectCount; ++obj) {
        if ((sdfObjects[obj].params.y & SDF_OBJECT_CASTS_SHADOWS) == 0u) continue;
        float reach = sdfConeUnbounded(obj) ? 0.0 : min(tMax, sdfConeFarthest(obj, o));
        vec2 iv = sdfConeInterval(obj, o, d, tanHalf * reach + epsilon);
        if (iv.x > iv.y || iv.y < tMin || iv.x > tMax) continue;
        if (g_coneCount < SDF_CONE_LIST) {
            g_coneList[g_coneCount] = obj;
            g_coneInterval[g_coneCount] = iv;
            ++g_coneCount;
        } else {
            g_coneOverflow = true;
        }
    }
    if (g_coneOverflow) g_coneCount = int(objectCount);
    return g_coneCount > 0;
}

// Conservative distance to the nearest listed occluder at the march point (ray parameter t).
float sdfConeDistance(vec3 p, float t, float fieldSafety) {
    float d = 3.0e38;
    for (int i = 0; i < g_coneCount; ++i) {
        uint obj = uint(i);
        if (!g_coneOverflow) {
            if (t > g_coneInterval[i].y) continue;  // the cone has left this (grown) box for good
            obj = g_coneList[i];
        } else if ((sdfObjects[obj].params.y & SDF_OBJECT_CASTS_SHADOWS) == 0u) {
            continue;
        }
        vec3 pl = sdfToLocal(obj, p);
        float box = sdfBoxDistance(obj, pl);
        if (box >= d) continue;  // cannot be nearer than the best so far
        d = min(d, sdfObjects[obj].boundsMin.w * sdfLocalDistance(obj, pl, fieldSafety));
    }
    return d;
}

float sdfConeVisibility(vec3 origin, vec3 dir, float tMin, float tMax, float sinHalfAngle, uint objectCount,
                        uint maxSteps, float fieldSafety, float epsilon) {
    bool hard = sinHalfAngle <= 0.0;
    float s = clamp(sinHalfAngle, 0.0, 0.999);
    float tanHalf = s / sqrt(1.0 - s * s);
    if (tMax <= tMin || !sdfConeCull(origin, dir, tMin, tMax, tanHalf, epsilon, objectCount)) return 1.0;
    float xMin = 1.0;
    float t = tMin;
    float d = 3.0e38;
    for (uint step = 0u; step < maxSteps && t < tMax; ++step) {
        d = sdfConeDistance(origin + dir * t, t, fieldSafety);
        if (hard) {
            if (d < epsilon) return 0.0;
            t += max(d, epsilon);
            continue;
        }
        float radius = t * s;  // from the axis point to the cone's surface
        // Outside an occluder the cone counts as at least epsilon wide: near its apex a step of
        // epsilon could otherwise jump a wall thinner than that unseen (d / radius stays large while
        // the radius is tiny). Inside (d < 0) the true radius keeps a thin wall's umbra dark.
        xMin = min(xMin, d / (d > 0.0 ? max(radius, epsilon) : max(radius, 1e-30)));
        if (xMin <= -1.0) return 0.0;
        // Plain sphere-tracing steps outside; inside an occluder |d| (the way out) still never
        // skips a deeper point by more than the sampling already does. At least a tenth of the
        // cone's radius and epsilon, so a ray along a surface does not stall.
        t += max(abs(d), max(0.1 * radius, epsilon));
    }
    // Out of steps while still creeping along a surface (a ray meeting it at a grazing angle takes
    // ever smaller steps): a hard ray within a few epsilons of it is taken as blocked.
    if (hard) return t < tMax && d < 4.0 * epsilon ? 0.0 : 1.0;
    return sdfDiscVisible(xMin);
}

float sdfSurfaceBias(vec3 p, float pixelSize, uint objectCount) {
    float bias = 0.25 * pixelSize;
#ifdef SDF_FIELDS
    float nearest = 3.0e38;
    float voxel = 0.0;
    for (uint obj = 0u; obj < objectCount; ++obj) {
        float v = sdfObjectVoxel(obj);
        if (v <= 0.0) continue;
        vec3 pl = sdfToLocal(obj, p);
        float box = sdfBoxDistance(obj, pl);
        if (box > 2.0 * v || box >= nearest) continue;
        float d = abs(sdfObjectDistance(obj, p, 0.0));
        if (d < nearest) {
            nearest = d;
            voxel = v;
        }
    }
    bias = max(bias, 1.5 * voxel);
#endif
    return bias;
}

#endif
