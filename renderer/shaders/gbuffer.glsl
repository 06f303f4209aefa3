// G-buffer encoding shared by every pass that writes or reads it (renderer/scene_renderer.h):
//   depth     R32_FLOAT    linear view depth (0 = nothing hit)
//   normal    RG16_FLOAT   world normal, octahedral encoding in [-1, 1]^2
//   material  RGBA8_UNORM  r, g = 16-bit material index (low byte, high byte) / 255,
//                          b, a = SDF object index + 1 (low byte, high byte) / 255: 0 for meshes
//                          and the background (sdf_surface finds an SDF pixel's object by it)
//   velocity  RG16_FLOAT   pixels moved since the previous frame (current - previous)
//   albedo    RGBA8_UNORM  optional: base colour, sRGB-encoded by packAlbedo (a UNORM target so the
//                          compute trace can write it as a storage image)
//   aux       RG32_FLOAT   optional: x entity index (-1 background), y sphere-trace steps
// The C++ octEncode / octDecode (renderer/core/gbuffer_encoding.h) are the same functions.

vec2 octSignNotZero(vec2 v) { return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }

// Unit vector -> [-1, 1]^2: project onto the octahedron |x|+|y|+|z| = 1, fold the lower half.
vec2 octEncode(vec3 n) {
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    return n.z >= 0.0 ? p : (1.0 - abs(p.yx)) * octSignNotZero(p);
}

vec3 octDecode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.x += n.x >= 0.0 ? -t : t;
    n.y += n.y >= 0.0 ? -t : t;
    return normalize(n);
}

// The material index (< 65536) and the SDF object index + 1 (< 65536; 0: not an SDF object) are
// each split into two UNORM8 bytes; k / 255 stored in UNORM8 reads back as exactly k / 255, so the
// round trip is exact.
vec4 packMaterial(uint index, uint sdfObject1) {
    return vec4(float(index & 255u) / 255.0, float((index >> 8u) & 255u) / 255.0,
                float(sdfObject1 & 255u) / 255.0, float((sdfObject1 >> 8u) & 255u) / 255.0);
}

uint unpackMaterialIndex(vec4 m) { return uint(m.r * 255.0 + 0.5) | (uint(m.g * 255.0 + 0.5) << 8u); }
// The SDF object index + 1 of a pixel (0: a mesh or the background).
uint unpackMaterialObject(vec4 m) { return uint(m.b * 255.0 + 0.5) | (uint(m.a * 255.0 + 0.5) << 8u); }

// Albedo (linear base colour) <-> the RGBA8_UNORM albedo target with the exact sRGB transfer
// functions (IEC 61966-2-1), as an RGBA8_SRGB target would store it.
float albedoEncode(float c) {
    c = clamp(c, 0.0, 1.0);
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}
float albedoDecode(float e) { return e <= 0.04045 ? e / 12.92 : pow((e + 0.055) / 1.055, 2.4); }
vec4 packAlbedo(vec3 c) { return vec4(albedoEncode(c.r), albedoEncode(c.g), albedoEncode(c.b), 1.0); }
vec3 unpackAlbedo(vec4 e) { return vec3(albedoDecode(e.r), albedoDecode(e.g), albedoDecode(e.b)); }
