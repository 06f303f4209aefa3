// sdf_tile_cull_bounds: the per-object half of the primary tile lists (sdf_tile_cull.comp is the
// per-tile half; renderer/features/sdf_cull.h). One invocation per object in [0, count) writes what
// every tile would otherwise recompute:
//   - the world box of the object's local bounds under `model`: centre relative to the camera and
//     three half axes, with its bounding sphere (the farthest corner; -1 for unbounded objects,
//     which every tile lists);
//   - a conservative rectangle of tiles: the projection of the bounding sphere lies in the hull of
//     its camera-aligned cube's projected corners (perspective maps convex sets in front of the
//     camera to convex sets), grown by one tile. Every tile whose frustum planes the sphere passes
//     lies inside it, so the per-tile pass may reject outside it before any plane test. Empty when
//     the sphere lies wholly before the near or behind the far plane; every tile when it reaches
//     the camera plane (no bounded projection) or a value is not finite.
// Projections use the View block's forward / rayRight / rayUp, the rays of sdf_trace.comp and of
// the tile planes, so no jitter or matrix convention can disagree with them.
#version 450
layout(local_size_x = 64) in;

#include "view.glsl"

// The layout of SdfObject in sdf_scene.glsl (sdf_cull.cpp checks it against GpuSdfObject).
struct SdfObject {
    mat4 worldToLocal;
    mat4 model;
    mat4 prevModel;
    vec4 boundsMin;  // xyz local bounds (+-1e30 when unbounded), w sigma_min
    vec4 boundsMax;
    uvec4 info;
    uvec4 params;
};

// Shared with sdf_tile_cull.comp (sdf_cull.cpp checks both against one C++ layout).
struct TileCullObject {
    vec4 centre;  // xyz box centre relative to the camera, w bounding radius (< 0: unbounded)
    vec4 axis0;   // xyz half axes of the box in world units (axis0.w: 1 for a baked field, else 0)
    vec4 axis1;
    vec4 axis2;
    uvec4 rect;  // tiles x0, y0, x1, y1 (inclusive; x0 > x1: no tile)
};

layout(set = 2, binding = 0, std430) readonly buffer SdfObjects { SdfObject sdfObjects[]; };
layout(set = 2, binding = 1, std430) writeonly buffer TileCullObjects { TileCullObject cullObjects[]; };

layout(push_constant) uniform SdfTileCullBounds {
    uvec4 counts;  // x objects, y tilesX, z tilesY
    vec4 clip;     // x near, y far (linear depth)
} bounds;

const uvec4 kNoTile = uvec4(1u, 1u, 0u, 0u);
const uint kKindField = 1u;  // SDF_KIND_FIELD of sdf_scene.glsl (info.x; sdf_cull.cpp checks it)

// The tile rectangle of a sphere at camera-relative centre c wholly in front of the camera.
uvec4 sphereTiles(vec3 c, float radius, vec3 fwd) {
    vec3 r = view.rayRight.xyz, u = view.rayUp.xyz;
    vec3 rn = normalize(r), un = normalize(u);
    float rr = dot(r, r), uu = dot(u, u);
    vec2 lo = vec2(3.0e38), hi = vec2(-3.0e38);
    for (int i = 0; i < 8; ++i) {
        vec3 s = vec3((i & 1) != 0 ? 1.0 : -1.0, (i & 2) != 0 ? 1.0 : -1.0, (i & 4) != 0 ? 1.0 : -1.0);
        vec3 q = c + radius * (s.x * rn + s.y * un + s.z * fwd);
        float depth = dot(q, fwd);
        vec2 ndc = vec2(dot(q, r) / rr, dot(q, u) / uu) / depth;
        vec2 pixel = (ndc * 0.5 + 0.5) * view.viewport.xy;
        lo = min(lo, pixel);
        hi = max(hi, pixel);
    }
    vec2 last = vec2(bounds.counts.yz) - 1.0;
    vec2 t0 = max(floor(lo / 8.0) - 1.0, vec2(0.0)), t1 = min(floor(hi / 8.0) + 1.0, last);
    if (any(isnan(lo)) || any(isnan(hi)) || any(isinf(lo)) || any(isinf(hi))) return uvec4(0u, 0u, uvec2(last));
    if (t0.x > t1.x || t0.y > t1.y) return kNoTile;
    return uvec4(uvec2(t0), uvec2(t1));
}

void main() {
    uint obj = gl_GlobalInvocationID.x;
    if (obj >= bounds.counts.x) return;
    uvec4 all = uvec4(0u, 0u, bounds.counts.yz - 1u);
    vec3 bmin = sdfObjects[obj].boundsMin.xyz, bmax = sdfObjects[obj].boundsMax.xyz;
    if (any(greaterThanEqual(abs(bmin), vec3(0.5e30))) || any(greaterThanEqual(abs(bmax), vec3(0.5e30)))) {
        cullObjects[obj] = TileCullObject(vec4(0.0, 0.0, 0.0, -1.0), vec4(0.0), vec4(0.0), vec4(0.0), all);
        return;
    }
    mat4 m = sdfObjects[obj].model;
    vec3 h = 0.5 * (bmax - bmin);
    vec3 c = (m * vec4(0.5 * (bmin + bmax), 1.0)).xyz - view.position.xyz;
    vec3 a0 = m[0].xyz * h.x, a1 = m[1].xyz * h.y, a2 = m[2].xyz * h.z;
    float radius = sqrt(max(max(dot(a0 + a1 + a2, a0 + a1 + a2), dot(a0 + a1 - a2, a0 + a1 - a2)),
                            max(dot(a0 - a1 + a2, a0 - a1 + a2), dot(a0 - a1 - a2, a0 - a1 - a2))));
    vec3 fwd = normalize(view.forward.xyz);
    float depth = dot(c, fwd);
    float slack = 1e-3 * (radius + length(c)) + 1e-6;  // beyond sdf_tile_cull.comp's plane margin
    uvec4 rect;
    if (depth + radius + slack < bounds.clip.x || depth - radius - slack > bounds.clip.y)
        rect = kNoTile;
    else if (!(depth - radius * 1.01 > 1e-4 * abs(depth) + 1e-6))
        rect = all;  // reaches the camera plane
    else
        rect = sphereTiles(c, radius * 1.01, fwd);
    float field = sdfObjects[obj].info.x == kKindField ? 1.0 : 0.0;
    cullObjects[obj] = TileCullObject(vec4(c, radius), vec4(a0, field), vec4(a1, 0.0), vec4(a2, 0.0), rect);
}
