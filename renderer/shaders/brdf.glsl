// Shading and display transforms of the deferred lighting pass. The C++ reference in
// renderer/passes/lighting_reference.h implements the same formulas (tests compare them); change
// both together.

const float kPi = 3.14159265358979;
const float kMinRoughness = 0.045;  // perceptual roughness floor (keeps alpha^2 representable)

// Schlick's Fresnel with F0 = mix(0.04, baseColor, metallic).
vec3 fresnelSchlick(vec3 f0, float vDotH) {
    float x = 1.0 - clamp(vDotH, 0.0, 1.0);
    float x2 = x * x;
    return f0 + (1.0 - f0) * (x2 * x2 * x);
}

// GGX / Trowbridge-Reitz normal distribution, alpha = roughness^2.
float ggxDistribution(float nDotH, float alpha) {
    float a2 = alpha * alpha;
    float d = nDotH * nDotH * (a2 - 1.0) + 1.0;
    return a2 / (kPi * d * d);
}

// Height-correlated Smith visibility for GGX: G2 / (4 nDotL nDotV).
float smithGgxCorrelated(float nDotV, float nDotL, float alpha) {
    float a2 = alpha * alpha;
    float gv = nDotL * sqrt(nDotV * nDotV * (1.0 - a2) + a2);
    float gl = nDotV * sqrt(nDotL * nDotL * (1.0 - a2) + a2);
    return 0.5 / (gv + gl);
}

// Blinn-Phong exponent from roughness: the Beckmann-equivalent mapping s = 2 / alpha^2 - 2 with
// alpha = roughness^2 (Walter et al. 2007), so roughness 1 gives s = 0 and smooth surfaces a sharp
// lobe; the lobe is energy-normalised by (s + 8) / (8 pi).
float blinnPhongExponent(float roughness) {
    float alpha = roughness * roughness;
    return 2.0 / (alpha * alpha) - 2.0;
}

// Reflected radiance towards v from one light of radiance `radiance` arriving along l (unit,
// pointing to the light), for unit normal n. shading: kShadingCookTorrance or kShadingBlinnPhong.
// Both models use Lambert diffuse weighted by (1 - F)(1 - metallic).
vec3 shadeLight(uint shading, vec3 n, vec3 v, vec3 l, vec3 radiance, vec3 baseColor, float metallic,
                float roughness) {
    float nDotL = dot(n, l);
    if (nDotL <= 0.0) return vec3(0.0);
    float nDotV = max(dot(n, v), 1e-4);
    vec3 h = normalize(v + l);
    float nDotH = max(dot(n, h), 0.0);
    float vDotH = max(dot(v, h), 0.0);
    roughness = clamp(roughness, kMinRoughness, 1.0);
    metallic = clamp(metallic, 0.0, 1.0);
    vec3 f0 = mix(vec3(0.04), baseColor, metallic);
    vec3 f = fresnelSchlick(f0, vDotH);
    vec3 specular;
    if (shading == kShadingBlinnPhong) {
        float s = blinnPhongExponent(roughness);
        specular = f * ((s + 8.0) / (8.0 * kPi)) * pow(max(nDotH, 1e-6), s);
    } else {
        float alpha = roughness * roughness;
        specular = f * (ggxDistribution(nDotH, alpha) * smithGgxCorrelated(nDotV, nDotL, alpha));
    }
    vec3 diffuse = (1.0 - f) * (1.0 - metallic) * baseColor / kPi;
    return (diffuse + specular) * radiance * nDotL;
}

// Distance falloff of point and sphere lights: inverse square with a smooth window that reaches 0
// at `range`:  clamp(1 - (d / range)^4, 0, 1)^2 / max(d, r)^2  with r = max(radius, 0.01) (the
// sphere's surface, or 1 cm for point lights, so the light never becomes infinite). range <= 0:
// no window.
float distanceFalloff(float d, float range, float radius) {
    float r = max(radius, 0.01);
    float dc = max(d, r);
    float window = 1.0;
    if (range > 0.0) {
        float x = d / range;
        float x2 = x * x;
        window = clamp(1.0 - x2 * x2, 0.0, 1.0);
        window *= window;
    }
    return window / (dc * dc);
}

// Tone mappers on exposed linear radiance: Clamp min(c, 1); Reinhard c / (1 + c) per channel;
// ACES: Narkowicz's 2015 fit of the ACES RRT + ODT, (c (2.51 c + 0.03)) / (c (2.43 c + 0.59) + 0.14),
// applied to the exposed colour as is (no extra 0.6 pre-scale), clamped to [0, 1].
vec3 toneMap(uint mapper, vec3 c) {
    c = max(c, vec3(0.0));
    if (mapper == kToneReinhard) return c / (1.0 + c);
    if (mapper == kToneAces) return clamp((c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14), 0.0, 1.0);
    return min(c, vec3(1.0));
}

// The exact piecewise sRGB OETF (IEC 61966-2-1).
float srgbEncode(float c) {
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}
vec3 srgbEncode(vec3 c) { return vec3(srgbEncode(c.r), srgbEncode(c.g), srgbEncode(c.b)); }
