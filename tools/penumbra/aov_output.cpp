#include "aov_output.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <glm/gtc/packing.hpp>

#include "renderer/core/gbuffer_encoding.h"
#include "renderer/renderer.h"
#include "renderer/scene_renderer.h"

namespace penumbra::cli {
namespace {

constexpr const char* kAovNames = "depth, normal, ids, steps, ao, shadow, shadowN, bentnormal, thickness";

bool parseAovName(const std::string& name, AovOutput& out) {
    for (RenderAov a : {RenderAov::Depth, RenderAov::Normal, RenderAov::Ids, RenderAov::Steps, RenderAov::Ao,
                        RenderAov::Shadow, RenderAov::BentNormal, RenderAov::Thickness})
        if (name == aovName(a)) {
            out.kind = a;
            return true;
        }
    // shadowN: shadowed light N (decimal, from 0)
    const std::string digits = name.size() > 6 && name.rfind("shadow", 0) == 0 ? name.substr(6) : "";
    if (digits.empty() || digits.size() > 6 ||
        !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
        return false;
    out.kind = RenderAov::Shadow;
    out.light = uint32_t(std::stoul(digits));
    return true;
}

bool isEffectAov(RenderAov a) {
    return a == RenderAov::Ao || a == RenderAov::Shadow || a == RenderAov::BentNormal ||
           a == RenderAov::Thickness;
}

// The effect target an effect AOV reads and, when it was not part of the frame, what turns it on.
const char* effectTarget(RenderAov a) {
    return a == RenderAov::Shadow      ? "effects.shadow"
           : a == RenderAov::Thickness ? "effects.thickness"
                                       : "effects.ao";
}
const char* effectHint(RenderAov a) {
    switch (a) {
        case RenderAov::Shadow:
            return "no shadow pass ran in the last frame: shadows need a light with castShadows, shadows on "
                   "(render.shadows.enabled; penumbra render --shadows on|hard) and SDF objects in the frame";
        case RenderAov::Thickness:
            return "no thickness pass ran in the last frame: it needs a material with subsurface > 0 and SDF "
                   "objects in the frame";
        default:
            return "AO did not run in the last frame: turn it on with render.ao.variant (penumbra render "
                   "--ao "
                   "five-tap|multi-ray|cones); it needs SDF objects in the frame";
    }
}

bool hasPfmExtension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return ext == ".pfm";
}

// The texels of one target, checked against the format and the image size.
bool checkTarget(const TargetTexels* t, const char* name, rhi::Format format, uint32_t width, uint32_t height,
                 std::string& error) {
    if (!t) {
        error = fmt::format("{} was not read back", name);
        return false;
    }
    if (t->format != format) {
        error = fmt::format("{} has format {}, expected {}", name, rhi::formatInfo(t->format).name,
                            rhi::formatInfo(format).name);
        return false;
    }
    const size_t expected = size_t(width) * height * rhi::formatInfo(format).bytesPerTexel;
    if (t->texels.size() != expected) {
        error = fmt::format("{} holds {} bytes, expected {} for {}x{}", name, t->texels.size(), expected,
                            width, height);
        return false;
    }
    return true;
}

float floatAt(const TargetTexels& t, size_t index) {
    float v;
    std::memcpy(&v, t.texels.data() + index * sizeof(float), sizeof(float));
    return v;
}

}  // namespace

const char* aovName(RenderAov aov) {
    switch (aov) {
        case RenderAov::Depth:
            return "depth";
        case RenderAov::Normal:
            return "normal";
        case RenderAov::Ids:
            return "ids";
        case RenderAov::Steps:
            return "steps";
        case RenderAov::Ao:
            return "ao";
        case RenderAov::Shadow:
            return "shadow";
        case RenderAov::BentNormal:
            return "bentnormal";
        case RenderAov::Thickness:
            return "thickness";
    }
    return "?";
}

std::string aovLabel(const AovOutput& aov) {
    return aov.kind == RenderAov::Shadow && aov.light > 0 ? fmt::format("shadow{}", aov.light)
                                                          : std::string(aovName(aov.kind));
}

CLI::Option* addAovOption(CLI::App* cmd, std::string& spec) {
    return cmd->add_option(
        "--aov", spec,
        "Also write float images of the last frame as PFM, comma-separated NAME=PATH.pfm: depth (linear view "
        "depth, 0: nothing hit), normal (world unit normal), ids (entity index, -1: background), steps "
        "(sphere-trace steps), ao (ambient occlusion), shadow / shadowN (visibility of the first / Nth "
        "shadowed "
        "light), bentnormal (AO bent normal), thickness (subsurface thickness); docs/FORMATS.md \"AOV "
        "images\"");
}

bool parseAovOutputs(const std::string& spec, std::vector<AovOutput>& out, std::string& error) {
    out.clear();
    if (spec.empty()) return true;
    std::stringstream ss(spec);
    std::string item;
    while (std::getline(ss, item, ',')) {
        const size_t eq = item.find('=');
        if (item.empty() || eq == std::string::npos || eq == 0 || eq + 1 == item.size()) {
            error = fmt::format("--aov '{}': expected NAME=PATH.pfm (e.g. depth=depth.pfm), NAME one of {}",
                                item, kAovNames);
            return false;
        }
        AovOutput a;
        const std::string name = item.substr(0, eq);
        a.path = item.substr(eq + 1);
        if (!parseAovName(name, a)) {
            error = fmt::format("--aov {}: unknown AOV '{}' ({})", item, name, kAovNames);
            return false;
        }
        for (const AovOutput& o : out)
            if (o.kind == a.kind && o.light == a.light) {
                error = fmt::format("--aov: AOV '{}' is listed twice", name);
                return false;
            }
        if (!hasPfmExtension(a.path)) {
            error = fmt::format(
                "--aov {}: AOV images are PFM (docs/FORMATS.md), so the file name must end in .pfm", item);
            return false;
        }
        out.push_back(a);
    }
    if (spec.back() == ',') {  // getline drops a trailing empty item
        error = fmt::format("--aov '{}': empty item after the last comma", spec);
        return false;
    }
    return true;
}

std::vector<std::string> aovPaths(const std::vector<AovOutput>& aovs) {
    std::vector<std::string> paths;
    for (const AovOutput& a : aovs) paths.push_back(a.path);
    return paths;
}

bool aovsNeedAux(const std::vector<AovOutput>& aovs) {
    return std::any_of(aovs.begin(), aovs.end(), [](const AovOutput& a) {
        return a.kind == RenderAov::Ids || a.kind == RenderAov::Steps;
    });
}

bool requestAuxTarget(RendererDesc& desc, const std::vector<AovOutput>& aovs, std::string&) {
    // gbuffer.aux (entity ids, trace steps) only when ids or steps are asked for.
    desc.aux = aovsNeedAux(aovs);
    return true;
}

bool convertAov(RenderAov aov, uint32_t width, uint32_t height, const TargetTexels* depth,
                const TargetTexels* normal, const TargetTexels* aux, reference::FloatImage& out,
                std::string& error) {
    const size_t pixels = size_t(width) * height;
    out.width = width;
    out.height = height;
    out.channels = aov == RenderAov::Normal ? 3 : 1;
    out.data.assign(pixels * out.channels, 0.0f);
    switch (aov) {
        case RenderAov::Depth:
            if (!checkTarget(depth, "gbuffer.depth", rhi::Format::R32_FLOAT, width, height, error))
                return false;
            std::memcpy(out.data.data(), depth->texels.data(), pixels * sizeof(float));
            return true;
        case RenderAov::Normal:
            if (!checkTarget(depth, "gbuffer.depth", rhi::Format::R32_FLOAT, width, height, error) ||
                !checkTarget(normal, "gbuffer.normal", rhi::Format::RG16_FLOAT, width, height, error))
                return false;
            for (size_t i = 0; i < pixels; ++i) {
                if (floatAt(*depth, i) == 0.0f) continue;  // nothing hit: 0, 0, 0
                uint16_t h[2];
                std::memcpy(h, normal->texels.data() + i * 4, 4);
                const glm::vec3 n = render::octDecode({glm::unpackHalf1x16(h[0]), glm::unpackHalf1x16(h[1])});
                out.data[i * 3 + 0] = n.x;
                out.data[i * 3 + 1] = n.y;
                out.data[i * 3 + 2] = n.z;
            }
            return true;
        case RenderAov::Ids:
        case RenderAov::Steps: {
            if (!checkTarget(aux, "gbuffer.aux", rhi::Format::RG32_FLOAT, width, height, error)) return false;
            const size_t channel = aov == RenderAov::Ids ? 0 : 1;
            for (size_t i = 0; i < pixels; ++i) out.data[i] = floatAt(*aux, i * 2 + channel);
            return true;
        }
        case RenderAov::Ao:
        case RenderAov::Shadow:
        case RenderAov::BentNormal:
        case RenderAov::Thickness:
            error = "an effect AOV (convertEffectAov converts it)";
            return false;
    }
    error = "unknown AOV";
    return false;
}

bool convertEffectAov(const AovOutput& aov, uint32_t width, uint32_t height, const TargetTexels& depth,
                      const TargetTexels& effect, reference::FloatImage& out, std::string& error) {
    if (!checkTarget(&depth, "gbuffer.depth", rhi::Format::R32_FLOAT, width, height, error)) return false;
    const size_t pixels = size_t(width) * height;
    out.width = width;
    out.height = height;
    out.channels = aov.kind == RenderAov::BentNormal ? 3 : 1;
    out.data.assign(pixels * out.channels, 0.0f);
    if (aov.kind == RenderAov::Shadow) {
        // width * layers x height: the layer count follows from the size
        const size_t layers = pixels ? effect.texels.size() / pixels : 0;
        if (effect.format != rhi::Format::R8_UNORM || layers * pixels != effect.texels.size()) {
            error = fmt::format("effects.shadow: {} bytes of {} do not make layers of {}x{}",
                                effect.texels.size(), rhi::formatInfo(effect.format).name, width, height);
            return false;
        }
        if (aov.light >= layers) {
            error = fmt::format(
                "the last frame has {} shadowed light(s) (shadow = the first, shadowN = light N "
                "from 0; lights with castShadows)",
                layers);
            return false;
        }
        for (size_t y = 0; y < height; ++y)
            for (size_t x = 0; x < width; ++x) {
                const size_t i = y * width + x;
                if (floatAt(depth, i) != 0.0f)
                    out.data[i] = effect.texels[y * width * layers + aov.light * width + x] / 255.0f;
            }
        return true;
    }
    if (aov.kind == RenderAov::Thickness) {
        if (!checkTarget(&effect, "effects.thickness", rhi::Format::R16_FLOAT, width, height, error))
            return false;
        for (size_t i = 0; i < pixels; ++i) {
            uint16_t h;
            std::memcpy(&h, effect.texels.data() + i * 2, 2);
            if (floatAt(depth, i) != 0.0f) out.data[i] = glm::unpackHalf1x16(h);
        }
        return true;
    }
    if (!checkTarget(&effect, "effects.ao", rhi::Format::RGBA8_UNORM, width, height, error)) return false;
    for (size_t i = 0; i < pixels; ++i) {
        if (floatAt(depth, i) == 0.0f) continue;
        const uint8_t* t = effect.texels.data() + i * 4;
        if (aov.kind == RenderAov::Ao) {
            out.data[i] = t[0] / 255.0f;
            continue;
        }
        const glm::vec3 b = glm::vec3(t[1], t[2], t[3]) / 255.0f * 2.0f - 1.0f;
        const glm::vec3 n = glm::dot(b, b) > 1e-12f ? glm::normalize(b) : glm::vec3(0.0f);
        for (int c = 0; c < 3; ++c) out.data[i * 3 + c] = n[c];
    }
    return true;
}

namespace {

bool writePfmOutput(OutputFiles& outputs, const std::string& path, const reference::FloatImage& image,
                    std::string& error) {
    return outputs.write(
        path,
        [&](const std::string& temp, std::string& why) {
            std::string pfmError;
            if (reference::writePfm(temp, image, pfmError)) return true;
            why = fmt::format("cannot write {}: {}", path, pfmError);
            return false;
        },
        error);
}

}  // namespace

bool writeAovOutputs(OutputFiles& outputs, render::SceneRenderer& renderer, uint32_t width, uint32_t height,
                     const std::vector<AovOutput>& aovs, std::string& error) {
    if (aovs.empty()) return true;
    bool needDepth = false, needNormal = false, needAux = false;
    for (const AovOutput& a : aovs) {
        needDepth |= a.kind != RenderAov::Ids && a.kind != RenderAov::Steps;
        needNormal |= a.kind == RenderAov::Normal;
        needAux |= a.kind == RenderAov::Ids || a.kind == RenderAov::Steps;
    }
    TargetTexels depth, normal, aux;
    auto read = [&](bool need, const char* name, TargetTexels& t) {
        if (!need) return true;
        if (renderer.readTarget(name, t.texels, t.format, error)) return true;
        error = fmt::format("--aov: {}", error);
        return false;
    };
    if (!read(needDepth, "gbuffer.depth", depth) || !read(needNormal, "gbuffer.normal", normal) ||
        !read(needAux, "gbuffer.aux", aux))
        return false;
    std::map<std::string, TargetTexels> effects;  // read back once each
    for (const AovOutput& a : aovs) {
        reference::FloatImage image;
        bool ok = false;
        if (isEffectAov(a.kind)) {
            const char* target = effectTarget(a.kind);
            auto it = effects.find(target);
            if (it == effects.end()) {
                TargetTexels t;
                std::string why;
                if (!renderer.readTarget(target, t.texels, t.format, why)) {
                    error = fmt::format("--aov {}: {}", aovLabel(a), effectHint(a.kind));
                    return false;
                }
                it = effects.emplace(target, std::move(t)).first;
            }
            ok = convertEffectAov(a, width, height, depth, it->second, image, error);
        } else {
            ok = convertAov(a.kind, width, height, &depth, &normal, &aux, image, error);
        }
        if (!ok) {
            error = fmt::format("--aov {}: {}", aovLabel(a), error);
            return false;
        }
        if (!writePfmOutput(outputs, a.path, image, error)) return false;
    }
    return true;
}

}  // namespace penumbra::cli
