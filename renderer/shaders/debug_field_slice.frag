// debug_field_slice, fragment stage: the signed distance of the frame's SDF scene on a plane
// (renderer/features/debug_field_slice.h documents the colours). Per pixel: the camera ray through
// the pixel centre (the sdf_trace ray) meets the plane dot(n, p) = offset at linear depth
// z in [near, far], else the pixel is black; at that point the distance is the minimum over every
// object of sdfObjectDistance (sdf_scene.glsl, the trace's conservative distance with its field
// safety), with no bounds culling. Variant SDF_FIELDS: the frame has field objects (atlas bound).
#version 450
#pragma penumbra_variants SDF_FIELDS
#include "view.glsl"

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 0
#define SHAPE_RECORDS_BINDING 1
#define SDF_FIELDS_BINDING 2
#define SDF_ATLAS_BINDING 3
#include "sdf_scene.glsl"

layout(push_constant) uniform FieldSlice {
    uvec4 counts;  // x SDF objects (0: the plane is drawn without a field)
    vec4 plane;    // xyz unit normal, w offset
    vec4 params;   // x iso-line spacing (scene units), y field safety, z near, w far (linear depth)
} slice;

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

const vec3 kOutside = vec3(1.0, 0.55, 0.15);
const vec3 kInside = vec3(0.2, 0.45, 1.0);
const vec3 kNoField = vec3(0.5);

void main() {
    vec2 ndc = gl_FragCoord.xy * view.viewport.zw * 2.0 - 1.0;
    vec3 dir = view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz;  // unit depth
    vec3 ro = view.position.xyz;
    vec3 n = slice.plane.xyz;
    float denom = dot(n, dir);
    // z: linear depth (dir has unit component along the view direction) where the ray meets the plane.
    float z = abs(denom) > 1e-12 ? (slice.plane.w - dot(n, ro)) / denom : -1.0;
    if (!(z >= slice.params.z && z <= slice.params.w)) {
        outColor = vec4(0.0, 0.0, 0.0, 1.0);
        return;
    }
    vec3 p = ro + dir * z;
    // w: the size of one pixel on the plane in scene units (the larger of the two pixel steps,
    // dp = z (ddir - dir (n . ddir) / (n . dir))), which bounds how much a 1-Lipschitz distance
    // changes from one pixel to the next. Computed, not taken with fwidth(d): a helper invocation's
    // storage-buffer reads are not defined (llvmpipe returns zeros), so d has no usable derivative.
    vec3 dx = view.rayRight.xyz * (2.0 * view.viewport.z), dy = view.rayUp.xyz * (2.0 * view.viewport.w);
    float w = max(z * max(length(dx - dir * (dot(n, dx) / denom)), length(dy - dir * (dot(n, dy) / denom))), 1e-7);
    float d = SHAPE_FAR;
    for (uint obj = 0u; obj < slice.counts.x; ++obj) d = min(d, sdfObjectDistance(obj, p, slice.params.y));

    // Base colour by side, darker with |d| (half brightness about 0.7 units away).
    vec3 colour = (d < 0.0 ? kInside : kOutside) * (0.3 + 0.7 * exp(-abs(d)));
    // Iso-lines every `spacing` units (minor, colour x 0.6) and every 10 spacings (major, x 0.35),
    // about one pixel wide; each set fades out where its lines would be fewer than 4 pixels apart
    // (gone at 2).
    for (int level = 0; level < 2; ++level) {
        float spacing = slice.params.x * (level == 0 ? 1.0 : 10.0);
        float toLine = abs(fract(d / spacing + 0.5) - 0.5) * spacing;
        float fade = clamp(spacing / w * 0.5 - 1.0, 0.0, 1.0);
        float line = 1.0 - smoothstep(0.5 * w, w, toLine);
        colour *= 1.0 - (level == 0 ? 0.4 : 0.65) * fade * line;
    }
    // The zero line (the surface): white, about three pixels wide; faded out as the major lines are
    // (far away, where one pixel spans a large part of the plane, it would mark everything).
    float zeroFade = clamp(10.0 * slice.params.x / w * 0.5 - 1.0, 0.0, 1.0);
    colour = mix(colour, vec3(1.0), zeroFade * (1.0 - smoothstep(1.0 * w, 1.75 * w, abs(d))));
    outColor = vec4(slice.counts.x == 0u ? kNoField : colour, 1.0);
}
