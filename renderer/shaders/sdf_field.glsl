// Object distance fields in the field atlas (renderer/features/sdf_atlas.h): the signed distance
// of one .psdf field at a point of its own (field = mesh) space, inside its grid and outside it,
// and a bound on what trilinear interpolation can add to it. tests/renderer/sdf_field_gpu_test.cpp
// checks it against exact mesh distances on both backends.
//
// Use: define the set and the bindings of the slot table and of the atlas, then include this file;
// it declares both (the block type name `SdfFields` and the sampler name `sdfAtlas` are the names
// ShaderParams binds them by):
//
//     #define SDF_FIELDS_SET 2
//     #define SDF_FIELDS_BINDING 0      // -> layout(set = 2, binding = 0, std430) readonly buffer
//     #define SDF_ATLAS_BINDING 1       //        SdfFields { SdfField sdfFields[]; };
//     #include "sdf_field.glsl"         // -> layout(set = 2, binding = 1) uniform sampler3D sdfAtlas;
//     float d = sdfFieldDistance(slot, p) - safety * sdfFieldInterpolationBound(slot, p);
//
// `SdfFields` holds SdfAtlas::fields() (one GpuSdfField per slot), `sdfAtlas` is SdfAtlas::texture()
// with a sampler of linear filtering and clamp-to-edge addressing (rhi::SamplerDesc's defaults).
//
// Values. The atlas stores distance / voxelSize rounded toward -infinity (sdf_atlas.h), so a stored
// value never exceeds the baked one. Inside the box of voxel centres B = [origin, origin + (dims -
// 1) * voxel] the distance is the hardware trilinear filter of the eight surrounding samples; outside
// B it is the conservative rule of sdf::SdfSampler (engine/sdf/psdf.h, docs/FORMATS.md) with the
// sample taken at q = clamp(p, B):
//     a = |p - q|, s = trilinear(q), toMesh = distance from p to the mesh bounds M
//     M inside B (flag boundsMin.w):  d = max(sqrt(a^2 + max(s, 0)^2), toMesh)
//     otherwise, toMesh > 0:          d = max(toMesh, s - a)
//     otherwise:                      d = s - a if s >= a;  s + a if s <= -a;  0 between
// The one departure from the CPU rule: a negative border sample (the mesh reaching B's border) is
// taken as 0 in the Pythagorean case, since sqrt(a^2 + s^2) with s < 0 needs |s| <= the true
// distance at q, which a value rounded toward -infinity does not promise; a <= dist(p) holds anyway.
//
// Interpolation bound. For a 1-Lipschitz field f (a signed distance) and corner values c_i <= f(c_i),
// the trilinear interpolant with weights w_i at p obeys  sum w_i c_i <= f(p) + sum w_i |c_i - p|
// (each f(c_i) <= f(p) + |c_i - p|). sdfFieldInterpolationBound returns that sum (0 at a voxel
// centre, at most sqrt(3)/2 voxel at a cell centre), taken at q outside B, plus a hardware term:
//   - GPUs filter with fixed-point sub-texel positions (8 fractional bits on desktop GPUs and on
//     llvmpipe/lavapipe; Vulkan's subTexelPrecisionBits), i.e. weights for a position up to 2^-8
//     texel away per axis, and the float texel coordinate itself is rounded (well below
//     atlasSize * 2^-22 texel). A weight error of e per axis moves the interpolant of the corner
//     distances |c_i - p| by at most e per axis (its partial derivatives are averages of
//     differences of a 1-Lipschitz function of the corners), so the term is
//     3 * (2^-8 + atlasSize * 2^-22) voxels: 0.0117 voxel for atlases up to 1024 texels a side.
//   - The sample position is moved at most SDF_FIELD_SHRINK texel per axis inside the slot's box
//     (sdfFieldSample), which by the same argument moves the interpolant by at most
//     3 * SDF_FIELD_SHRINK voxels (0.047), added to the term.
//   - The filter arithmetic is assumed to be at least float precision (it is on llvmpipe/lavapipe
//     and on the desktop GPUs we know of); its rounding (2^-24 of the corner values) is absorbed
//     by the term above.
// So  sdfFieldDistance(slot, p) - sdfFieldInterpolationBound(slot, p) <= f(p)  (to the float
// rounding of the evaluation, 1e-5 relative in the tests) at every p inside B, signed, and at every
// p outside the surface outside B; subtracting the bound with a safety factor >= 1 keeps a sphere
// tracer from stepping through a surface. The same bound also limits how far below f(p) the
// interpolant can be (|trilinear - f| <= bound + the storage rounding, < 2^-10 relative).
//
// Precision of positions: field-space points, the origin and the bounds are floats; the atlas
// rounds the mesh bounds outward. Points should be within ~1e4 voxels of the field (the trace's
// concern): beyond that the distance is dominated by toMesh, exact to float rounding.

#ifndef SDF_FIELDS_SET
#error "define SDF_FIELDS_SET, SDF_FIELDS_BINDING and SDF_ATLAS_BINDING before including sdf_field.glsl"
#endif

// One slot: render::GpuSdfField (std430, 96 bytes).
struct SdfField {
    vec4 origin;     // xyz: field-space position of voxel (0,0,0)'s centre; w: voxel size
    vec4 uvwScale;   // xyz: 1 / atlas size in texels
    vec4 uvwOffset;  // xyz: the slot's first texel
    vec4 dims;       // xyz: voxels per axis
    vec4 boundsMin;  // xyz: source mesh bounds min (rounded down); w: 1 when the bounds lie in B
    vec4 boundsMax;  // xyz: source mesh bounds max (rounded up)
};

layout(set = SDF_FIELDS_SET, binding = SDF_FIELDS_BINDING, std430) readonly buffer SdfFields {
    SdfField sdfFields[];
};
layout(set = SDF_FIELDS_SET, binding = SDF_ATLAS_BINDING) uniform sampler3D sdfAtlas;

// |v| without overflow for large components (and 0 for v = 0).
float sdfSafeLength(vec3 v) {
    float m = max(max(abs(v.x), abs(v.y)), abs(v.z));
    return m > 0.0 ? m * length(v / m) : 0.0;
}

float sdfFieldVoxelSize(uint slot) { return sdfFields[slot].origin.w; }

// Position of p in voxel units from voxel (0,0,0)'s centre: B is [0, dims - 1].
vec3 sdfFieldVoxelCoord(SdfField f, vec3 p) { return (p - f.origin.xyz) / f.origin.w; }

// Inward shrink of the sampled box, in texels: the texel coordinate's float rounding (~1e-7 of the
// atlas size) stays far below it, so the filter never gives a texel of a neighbouring slot a
// non-zero weight. The interpolation bound adds 3 * SDF_FIELD_SHRINK voxel for it.
const float SDF_FIELD_SHRINK = 0.015625;

// Hardware trilinear sample at voxel coordinate x in [0, dims - 1], in field units, taken at most
// SDF_FIELD_SHRINK texel inside the slot's box of texel centres (at its middle on a one-voxel axis).
float sdfFieldSample(SdfField f, vec3 x) {
    vec3 hi = f.dims.xyz - 1.0;
    vec3 lo = min(vec3(SDF_FIELD_SHRINK), 0.5 * hi);
    x = clamp(x, lo, hi - lo);
    vec3 uvw = (f.uvwOffset.xyz + 0.5 + x) * f.uvwScale.xyz;
    return textureLod(sdfAtlas, uvw, 0.0).r * f.origin.w;
}

float sdfFieldDistanceOf(SdfField f, vec3 p) {
    float voxel = f.origin.w;
    vec3 x = sdfFieldVoxelCoord(f, p);
    vec3 qx = clamp(x, vec3(0.0), f.dims.xyz - 1.0);
    float s = sdfFieldSample(f, qx);
    vec3 off = x - qx;
    if (off == vec3(0.0)) return s;  // inside B (or on it): trilinear
    float a = sdfSafeLength(off) * voxel;
    float toMesh = sdfSafeLength(max(max(f.boundsMin.xyz - p, p - f.boundsMax.xyz), vec3(0.0)));
    if (f.boundsMin.w > 0.5) {
        float sp = max(s, 0.0);
        float m = max(a, sp);
        float pyth = m * sqrt(1.0 + (min(a, sp) / m) * (min(a, sp) / m));  // sqrt(a^2 + sp^2), a > 0
        return max(pyth, toMesh);
    }
    if (toMesh > 0.0) return max(toMesh, s - a);
    if (s >= a) return s - a;
    if (s <= -a) return s + a;
    return 0.0;
}

// The hardware term of the interpolation bound, in voxels: 3 * (2^-8 + size * 2^-22) for the filter's
// weights and coordinate rounding, plus the shrink.
float sdfFieldHardwareTerm(SdfField f) {
    float atlasSize = 1.0 / min(min(f.uvwScale.x, f.uvwScale.y), f.uvwScale.z);
    return 3.0 * (0.00390625 + atlasSize * 2.384185791015625e-7) + 3.0 * SDF_FIELD_SHRINK;
}

// The slot-indexed forms; the *Of forms take a record already loaded (a caller that needs both
// loads it once).
float sdfFieldDistance(uint slot, vec3 p) { return sdfFieldDistanceOf(sdfFields[slot], p); }

float sdfFieldInterpolationBoundOf(SdfField f, vec3 p) {
    vec3 hi = f.dims.xyz - 1.0;
    vec3 x = clamp(sdfFieldVoxelCoord(f, p), vec3(0.0), hi);
    vec3 t = x - min(floor(x), max(hi - 1.0, vec3(0.0)));  // in [0, 1]; 0 on a one-voxel axis
    float sum = 0.0;
    for (int k = 0; k < 8; ++k) {
        vec3 c = vec3(float(k & 1), float((k >> 1) & 1), float((k >> 2) & 1));
        vec3 w = mix(1.0 - t, t, c);
        sum += w.x * w.y * w.z * length(c - t);
    }
    return (sum + sdfFieldHardwareTerm(f)) * f.origin.w;
}

float sdfFieldInterpolationBound(uint slot, vec3 p) { return sdfFieldInterpolationBoundOf(sdfFields[slot], p); }

// A lower bound of the distance from p to the zero set, within B, of the trilinear interpolant of the
// field's stored values (the surface the hit decision's cell walk finds, sdf_march.glsl); raw is the
// field's distance at p (sdfFieldDistance) and bound its interpolation bound there. Inside B the
// larger of two bounds:
//   - Lipschitz: along an edge two stored values differ by at most one voxel (samples of a
//     1-Lipschitz distance, rounded toward -infinity as halfs: at most 2^-8 voxel more where the
//     values are under 8 voxels, which is where this bound is the larger one), so each partial
//     derivative of the interpolant is at most 1.004 and its gradient at most sqrt(3) * 1.004 <
//     1.75; the filtered value exceeds the interpolant by at most the hardware term hw:
//     (raw - hw) / 1.75.
//   - Through the true distance f: at a zero q of the interpolant f(q) is at most its interpolation
//     bound there, at most sqrt(3) / 2 voxel plus hw (the margin), and f(p) >= raw - bound; so the
//     distance is at least raw - bound - margin (the larger one beyond about 4 voxels).
// Outside B the larger of the second bound and the distance to B.
float sdfFieldRootDistance(SdfField f, vec3 p, float raw, float bound) {
    float hw = sdfFieldHardwareTerm(f) * f.origin.w;
    float margin = 0.8660254 * f.origin.w + hw;
    float through = raw - bound - margin;
    vec3 x = sdfFieldVoxelCoord(f, p);
    vec3 off = x - clamp(x, vec3(0.0), f.dims.xyz - 1.0);
    if (off != vec3(0.0)) return max(sdfSafeLength(off) * f.origin.w, through);
    return max((raw - hw) * (1.0 / 1.75), through);
}
