// CPU reference of the deferred lighting pass: the same BRDFs, light falloff, tone mappers and sRGB
// encoding as renderer/shaders/brdf.glsl and deferred_lighting_fs.glsl, in C++ (float, like the
// GPU), so tests can compare GPU output against them. Change both together.
//
// Conventions: n, v, l are unit world vectors; v points from the surface to the eye, l from the
// surface to the light. Radiance is linear RGB; `shadeLight` returns the reflected radiance
// f(v, l) * radiance * max(n.l, 0).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "engine/ecs/components.h"
#include "engine/scene/scene.h"

namespace penumbra::render::reference {

inline constexpr float kPi = 3.14159265358979f;
inline constexpr float kMinRoughness = 0.045f;  // perceptual roughness floor

inline glm::vec3 fresnelSchlick(glm::vec3 f0, float vDotH) {
    float x = 1.0f - std::clamp(vDotH, 0.0f, 1.0f);
    float x2 = x * x;
    return f0 + (glm::vec3(1.0f) - f0) * (x2 * x2 * x);
}

// GGX normal distribution, alpha = roughness^2.
inline float ggxDistribution(float nDotH, float alpha) {
    float a2 = alpha * alpha;
    float d = nDotH * nDotH * (a2 - 1.0f) + 1.0f;
    return a2 / (kPi * d * d);
}

// Height-correlated Smith visibility G2 / (4 n.l n.v) for GGX.
inline float smithGgxCorrelated(float nDotV, float nDotL, float alpha) {
    float a2 = alpha * alpha;
    float gv = nDotL * std::sqrt(nDotV * nDotV * (1.0f - a2) + a2);
    float gl = nDotV * std::sqrt(nDotL * nDotL * (1.0f - a2) + a2);
    return 0.5f / (gv + gl);
}

// Blinn-Phong exponent: s = 2 / alpha^2 - 2, alpha = roughness^2 (Beckmann-equivalent mapping).
inline float blinnPhongExponent(float roughness) {
    float alpha = roughness * roughness;
    return 2.0f / (alpha * alpha) - 2.0f;
}

// Reflected radiance from one light (see brdf.glsl shadeLight): Cook-Torrance (GGX, height-correlated
// Smith, Schlick Fresnel) or normalised Blinn-Phong ((s + 8) / (8 pi) n.h^s, Schlick Fresnel), both
// with Lambert diffuse weighted by (1 - F)(1 - metallic); F0 = mix(0.04, baseColor, metallic).
inline glm::vec3 shadeLight(scene::ShadingModel shading, glm::vec3 n, glm::vec3 v, glm::vec3 l,
                            glm::vec3 radiance, glm::vec3 baseColor, float metallic, float roughness) {
    float nDotL = glm::dot(n, l);
    if (nDotL <= 0.0f) return glm::vec3(0.0f);
    float nDotV = std::max(glm::dot(n, v), 1e-4f);
    glm::vec3 h = glm::normalize(v + l);
    float nDotH = std::max(glm::dot(n, h), 0.0f);
    float vDotH = std::max(glm::dot(v, h), 0.0f);
    roughness = std::clamp(roughness, kMinRoughness, 1.0f);
    metallic = std::clamp(metallic, 0.0f, 1.0f);
    glm::vec3 f0 = glm::mix(glm::vec3(0.04f), baseColor, metallic);
    glm::vec3 f = fresnelSchlick(f0, vDotH);
    glm::vec3 specular;
    if (shading == scene::ShadingModel::BlinnPhong) {
        float s = blinnPhongExponent(roughness);
        specular = f * ((s + 8.0f) / (8.0f * kPi)) * std::pow(std::max(nDotH, 1e-6f), s);
    } else {
        float alpha = roughness * roughness;
        specular = f * (ggxDistribution(nDotH, alpha) * smithGgxCorrelated(nDotV, nDotL, alpha));
    }
    glm::vec3 diffuse = (glm::vec3(1.0f) - f) * (1.0f - metallic) * baseColor / kPi;
    return (diffuse + specular) * radiance * nDotL;
}

// Point / sphere light falloff: clamp(1 - (d / range)^4, 0, 1)^2 / max(d, max(radius, 0.01))^2;
// range <= 0 disables the window.
inline float distanceFalloff(float d, float range, float radius) {
    float r = std::max(radius, 0.01f);
    float dc = std::max(d, r);
    float window = 1.0f;
    if (range > 0.0f) {
        float x = d / range;
        float x2 = x * x;
        window = std::clamp(1.0f - x2 * x2, 0.0f, 1.0f);
        window *= window;
    }
    return window / (dc * dc);
}

// Clamp: min(c, 1); Reinhard: c / (1 + c); ACES: Narkowicz 2015 fit
// (c (2.51 c + 0.03)) / (c (2.43 c + 0.59) + 0.14) on the exposed colour, clamped to [0, 1].
inline float toneMap(scene::ToneMapper mapper, float c) {
    c = std::max(c, 0.0f);
    switch (mapper) {
        case scene::ToneMapper::Reinhard:
            return c / (1.0f + c);
        case scene::ToneMapper::Aces:
            return std::clamp((c * (2.51f * c + 0.03f)) / (c * (2.43f * c + 0.59f) + 0.14f), 0.0f, 1.0f);
        case scene::ToneMapper::Clamp:
            break;
    }
    return std::min(c, 1.0f);
}

// Exact piecewise sRGB OETF.
inline float srgbEncode(float c) {
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

// Linear radiance -> the 8-bit value the lighting pass stores: exposure, tone map, sRGB, round.
inline std::array<uint8_t, 3> displayEncode(glm::vec3 radiance, float exposure, scene::ToneMapper mapper) {
    std::array<uint8_t, 3> out{};
    for (int i = 0; i < 3; ++i) {
        float v = srgbEncode(toneMap(mapper, radiance[i] * exposure));
        out[size_t(i)] = uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
    }
    return out;
}

// A light as the lighting pass sees it.
struct LightSample {
    ecs::LightType type = ecs::LightType::Directional;
    glm::vec3 position{0.0f};   // point / sphere
    glm::vec3 direction{0.0f};  // directional: unit direction the light travels
    glm::vec3 radiance{0.0f};   // colour * intensity
    float range = 0.0f;
    float radius = 0.0f;
};

// From the ECS: position = worldPosition(), direction = worldForward() (the light's local -Z).
inline LightSample makeLightSample(const ecs::Light& light, const ecs::Transform& transform) {
    LightSample s;
    s.type = light.type;
    s.position = transform.worldPosition();
    s.direction = transform.worldForward();
    s.radiance = light.color * light.intensity;
    s.range = light.range;
    s.radius = light.type == ecs::LightType::Sphere ? light.radius : 0.0f;
    return s;
}

// A shaded G-buffer sample.
struct SurfaceSample {
    glm::vec3 position{0.0f};
    glm::vec3 normal{0.0f, 0.0f, 1.0f};
    glm::vec3 baseColor{1.0f};
    float metallic = 0.0f;
    float roughness = 0.5f;
    glm::vec3 emissive{0.0f};
    float ao = 1.0f;
    float shadow = 1.0f;
};

// Linear radiance leaving `s` towards the eye at `eye` (before exposure): ambient * baseColor * ao
// + emissive + shadow * sum over lights.
// `visibility`: each light's shadow visibility (the GPU's effects.shadow layer of that light), 1
// for every light when empty; it multiplies s.shadow.
inline glm::vec3 shadeSurface(scene::ShadingModel shading, glm::vec3 ambient, const SurfaceSample& s,
                              glm::vec3 eye, std::span<const LightSample> lights,
                              std::span<const float> visibility = {}) {
    glm::vec3 v = glm::normalize(eye - s.position);
    glm::vec3 radiance = ambient * s.baseColor * s.ao + s.emissive;
    for (size_t i = 0; i < lights.size(); ++i) {
        const LightSample& light = lights[i];
        const float shadow = s.shadow * (i < visibility.size() ? visibility[i] : 1.0f);
        glm::vec3 l;
        glm::vec3 incoming = light.radiance;
        if (light.type == ecs::LightType::Directional) {
            l = -light.direction;
        } else {
            glm::vec3 toLight = light.position - s.position;
            float d = glm::length(toLight);
            l = d > 0.0f ? toLight / d : s.normal;
            incoming *= distanceFalloff(d, light.range, light.radius);
        }
        radiance +=
            shadow * shadeLight(shading, s.normal, v, l, incoming, s.baseColor, s.metallic, s.roughness);
    }
    return radiance;
}

}  // namespace penumbra::render::reference
