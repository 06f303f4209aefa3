#include <algorithm>
#include <cctype>
#include <string>

#include "rhi/types.h"

namespace rhi {

const char* toString(Backend b) {
    switch (b) {
        case Backend::Auto:
            return "auto";
        case Backend::Vulkan:
            return "vulkan";
        case Backend::OpenGL:
            return "gl";
        case Backend::Null:
            return "null";
    }
    return "?";
}

bool parseBackend(std::string_view text, Backend& out) {
    std::string s(text);
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (s == "vulkan" || s == "vk")
        out = Backend::Vulkan;
    else if (s == "gl" || s == "opengl")
        out = Backend::OpenGL;
    else if (s == "null")
        out = Backend::Null;
    else if (s == "auto")
        out = Backend::Auto;
    else
        return false;
    return true;
}

const FormatInfo& formatInfo(Format f) {
    // name, bytes, channels, depth, integer, srgb
    static const FormatInfo kInfo[] = {
        {"Undefined", 0, 0, false, false, false},    {"R8_UNORM", 1, 1, false, false, false},
        {"R8_UINT", 1, 1, false, true, false},       {"R16_FLOAT", 2, 1, false, false, false},
        {"R32_FLOAT", 4, 1, false, false, false},    {"R32_UINT", 4, 1, false, true, false},
        {"RG16_FLOAT", 4, 2, false, false, false},   {"RG32_FLOAT", 8, 2, false, false, false},
        {"RGBA8_UNORM", 4, 4, false, false, false},  {"RGBA8_SRGB", 4, 4, false, false, true},
        {"RGBA16_FLOAT", 8, 4, false, false, false}, {"RGBA32_FLOAT", 16, 4, false, false, false},
        {"D32_FLOAT", 4, 1, true, false, false},     {"RGB32_FLOAT", 12, 3, false, false, false},
    };
    static_assert(sizeof(kInfo) / sizeof(kInfo[0]) == size_t(Format::Count));
    size_t i = size_t(f);
    return i < size_t(Format::Count) ? kInfo[i] : kInfo[0];
}

namespace {
// The names of the set bits (bit i named names[i]) joined by '|', or `none` when no bit is set.
std::string joinBits(uint32_t bits, std::span<const char* const> names, const char* none) {
    std::string out;
    for (uint32_t bit = 0; bit < names.size(); ++bit) {
        if (bits & (1u << bit)) {
            if (!out.empty()) out += '|';
            out += names[bit];
        }
    }
    return out.empty() ? none : out;
}
}  // namespace

std::string toString(Access a) {
    static const char* const kNames[] = {"ShaderSampled",    "ShaderRead",      "ShaderWrite",  "UniformRead",
                                         "VertexRead",       "IndexRead",       "IndirectRead", "ColorTarget",
                                         "DepthTargetWrite", "DepthTargetRead", "CopySrc",      "CopyDst",
                                         "HostRead",         "HostWrite",       "Present"};
    return joinBits(uint32_t(a), kNames, "None");
}

std::string toString(FormatSupport s) {
    static const char* const kNames[] = {"sampled", "filterable", "storage", "atomic",
                                         "colour",  "blend",      "depth",   "vertex"};
    return joinBits(uint32_t(s), kNames, "none");
}

std::string toString(SubgroupOps ops) {
    static const char* const kNames[] = {
        "basic", "vote", "arithmetic", "ballot", "shuffle", "shuffle-relative", "clustered", "quad"};
    return joinBits(uint32_t(ops), kNames, "none");
}

}  // namespace rhi
