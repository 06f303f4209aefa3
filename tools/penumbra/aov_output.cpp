#include "aov_output.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <sstream>

#include <fmt/format.h>
#include <glm/gtc/packing.hpp>

#include "renderer/core/gbuffer_encoding.h"
#include "renderer/renderer.h"
#include "renderer/scene_renderer.h"

namespace penumbra::cli {
namespace {

constexpr const char* kAovNames = "depth, normal, ids, steps";

bool parseAovName(const std::string& name, RenderAov& out) {
    for (RenderAov a : {RenderAov::Depth, RenderAov::Normal, RenderAov::Ids, RenderAov::Steps})
        if (name == aovName(a)) {
            out = a;
            return true;
        }
    return false;
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
    }
    return "?";
}

CLI::Option* addAovOption(CLI::App* cmd, std::string& spec) {
    return cmd->add_option(
        "--aov", spec,
        "Also write float images of the last frame as PFM, comma-separated NAME=PATH.pfm: depth (linear view "
        "depth, 0: nothing hit), normal (world unit normal), ids (entity index, -1: background), steps "
        "(sphere-trace steps); docs/FORMATS.md \"AOV images\"");
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
        if (!parseAovName(name, a.kind)) {
            error = fmt::format("--aov {}: unknown AOV '{}' ({})", item, name, kAovNames);
            return false;
        }
        for (const AovOutput& o : out)
            if (o.kind == a.kind) {
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
    }
    error = "unknown AOV";
    return false;
}

bool writeAovOutputs(OutputFiles& outputs, render::SceneRenderer& renderer, uint32_t width, uint32_t height,
                     const std::vector<AovOutput>& aovs, std::string& error) {
    if (aovs.empty()) return true;
    bool needDepth = false, needNormal = false, needAux = false;
    for (const AovOutput& a : aovs) {
        needDepth |= a.kind == RenderAov::Depth || a.kind == RenderAov::Normal;
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
    for (const AovOutput& a : aovs) {
        reference::FloatImage image;
        if (!convertAov(a.kind, width, height, &depth, &normal, &aux, image, error)) {
            error = fmt::format("--aov {}: {}", aovName(a.kind), error);
            return false;
        }
        const bool ok = outputs.write(
            a.path,
            [&](const std::string& temp, std::string& why) {
                std::string pfmError;
                if (reference::writePfm(temp, image, pfmError)) return true;
                why = fmt::format("cannot write {}: {}", a.path, pfmError);
                return false;
            },
            error);
        if (!ok) return false;
    }
    return true;
}

}  // namespace penumbra::cli
