#include "cli_common.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>

#include <fmt/format.h>

#include "engine/core/log.h"

namespace penumbra::cli {

namespace {

const char* kNullBackendReason =
    "the null backend records commands but executes none, so the output would be blank; use vulkan or gl";

}  // namespace

CLI::Option* addBackendOption(CLI::App* cmd, std::string& backend) {
    return cmd
        ->add_option("--backend", backend,
                     "Graphics backend: vulkan | gl (default: $PENUMBRA_BACKEND, else auto)")
        ->check(CLI::Validator(
            [](std::string& value) -> std::string {
                rhi::Backend b;
                if (!rhi::parseBackend(value, b))
                    return fmt::format("'{}' is not a backend (allowed: vulkan, vk, gl, opengl, auto)",
                                       value);
                if (b == rhi::Backend::Null) return kNullBackendReason;
                return {};
            },
            "vulkan|gl|auto"));
}

CLI::Option* addSizeOption(CLI::App* cmd, const std::string& name, uint32_t& value, const std::string& help) {
    return cmd->add_option(name, value, help)
        ->check(CLI::Validator(
            [name](std::string& text) -> std::string {
                uint64_t n = 0;
                bool ok = !text.empty() && text.size() <= 10;
                for (char c : text) ok = ok && std::isdigit(static_cast<unsigned char>(c));
                if (ok) n = std::strtoull(text.c_str(), nullptr, 10);
                if (ok && n >= 1 && n <= std::numeric_limits<uint32_t>::max()) return {};
                return fmt::format(
                    "'{}' is not allowed: {} takes a whole number of pixels from 1 to the device's maximum "
                    "2D texture size (`penumbra info` prints it)",
                    text, name);
            },
            "1..device max"));
}

bool chooseBackend(const std::string& flag, const char* command, rhi::Backend& out, std::string& error) {
    out = rhi::Backend::Auto;
    if (!flag.empty()) {
        if (!rhi::parseBackend(flag, out)) {
            error = fmt::format("{}: unknown backend '{}'", command, flag);
            return false;
        }
        if (out == rhi::Backend::Null) {
            error = fmt::format("{}: --backend null: {}", command, kNullBackendReason);
            return false;
        }
        return true;
    }
    const char* env = std::getenv("PENUMBRA_BACKEND");
    rhi::Backend fromEnv;
    if (env && *env && rhi::parseBackend(env, fromEnv) && fromEnv == rhi::Backend::Null) {
        error = fmt::format("{}: PENUMBRA_BACKEND=null: {} (unset it or pass --backend)", command,
                            kNullBackendReason);
        return false;
    }
    return true;  // Auto: createDevice applies $PENUMBRA_BACKEND (or warns about a bad value)
}

bool refuseNullDevice(const rhi::Device& device, const char* command, std::string& error) {
    if (device.info().backend != rhi::Backend::Null) return true;
    error = fmt::format("{}: {}", command, kNullBackendReason);
    return false;
}

bool checkImageSize(uint32_t width, uint32_t height, const rhi::Device& device, const std::string& source,
                    std::string& error) {
    const rhi::DeviceInfo& info = device.info();
    const uint32_t maxSize = info.limits.maxTextureSize2D;
    if (width >= 1 && height >= 1 && width <= maxSize && height <= maxSize) return true;
    error = fmt::format(
        "{} {}x{} is outside what the device can render: each side must be from 1 to the device's maximum 2D "
        "texture size {} ({} on {})",
        source, width, height, maxSize, rhi::toString(info.backend), info.deviceName);
    return false;
}

bool checkInputFile(const std::string& path, const std::string& what, std::string& error) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) {
        error = fmt::format("{}: {}", path, std::strerror(errno));
        return false;
    }
    if (S_ISDIR(st.st_mode)) {
        error = fmt::format("{} is a directory, not a {}", path, what);
        return false;
    }
    if (!S_ISREG(st.st_mode)) {
        error = fmt::format("{} is not a regular file (expected a {})", path, what);
        return false;
    }
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        error = fmt::format("{}: cannot open: {}", path, std::strerror(errno));
        return false;
    }
    ::close(fd);
    return true;
}

bool checkPngPath(const std::string& path, const std::string& option, std::string& error) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".png") return true;
    error = fmt::format(
        "{} {}: {}: penumbra writes PNG images only, so the file name must end in .png", option, path,
        ext.empty()
            ? std::string("the file name has no extension")
            : fmt::format("unknown image extension '{}'", std::filesystem::path(path).extension().string()));
    return false;
}

bool writePngOutput(OutputFiles& outputs, const std::string& path, const ImageRGBA8& image,
                    std::string& error) {
    return outputs.write(
        path,
        [&](const std::string& temp, std::string& why) {
            std::string pngError;
            if (writePng(temp, image, &pngError)) return true;
            why = fmt::format("cannot write {}: {}", path, pngError);
            return false;
        },
        error);
}

bool prepareOutputs(OutputFiles& outputs, const std::vector<std::string>& paths, const char* command) {
    std::string error;
    for (const std::string& path : paths) {
        if (path.empty()) continue;
        if (!outputs.add(path, error)) {
            log::error("{}: {}", command, error);
            return false;
        }
    }
    return true;
}

CLI::Option* addBenchBackendOption(CLI::App* cmd, std::string& value) {
    return cmd->add_option("--backend", value, "vulkan (vk) | gl (opengl) | both: Vulkan, then OpenGL")
        ->check(CLI::Validator(
            [](std::string& v) -> std::string {
                rhi::Backend b;
                if (v == "both") return {};
                if (!rhi::parseBackend(v, b) || b == rhi::Backend::Auto || b == rhi::Backend::Null)
                    return fmt::format("'{}' is not allowed: --backend takes vulkan, vk, gl, opengl or both",
                                       v);
                return {};
            },
            "vk|gl|both"))
        ->capture_default_str();
}

bool benchBackends(const std::string& value, std::vector<rhi::Backend>& out) {
    if (value == "both") {
        out = {rhi::Backend::Vulkan, rhi::Backend::OpenGL};
        return true;
    }
    rhi::Backend b;
    if (!rhi::parseBackend(value, b) || b == rhi::Backend::Auto || b == rhi::Backend::Null) return false;
    out = {b};
    return true;
}

std::string defaultCacheDir() {
    if (const char* env = std::getenv("PENUMBRA_CACHE_DIR"); env && *env) return env;
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::string(xdg) + "/penumbra";
    if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.cache/penumbra";
    return {};
}

double median(std::vector<double> v) {
    v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
    if (v.empty()) return std::nan("");
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string loadAverage() {
    std::ifstream in("/proc/loadavg");
    double one = 0, five = 0, fifteen = 0;
    if (!(in >> one >> five >> fifteen)) return "unknown";
    return fmt::format("{:.2f} / {:.2f} / {:.2f} (1 / 5 / 15 min)", one, five, fifteen);
}

std::string cpuModel() {
    std::ifstream in("/proc/cpuinfo");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("model name", 0) == 0 && line.find(':') != std::string::npos)
            return line.substr(line.find(':') + 2);
    return "unknown CPU";
}

std::string utcNow() {
    char date[64];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    return date;
}

CLI::Option* addAccelOption(CLI::App* cmd, std::string& value) {
    return cmd->add_option(
        "--accel", value,
        "Acceleration toggles (replace the scene's render.acceleration ones): all | none | a "
        "comma-separated list of culling, cache, id, prepass (exactly those on; all = culling, cache "
        "and id; docs/FORMATS.md)");
}

bool applyAccelOption(const std::string& value, scene::AccelerationSettings& accel, std::string& error) {
    if (value.empty()) return true;
    scene::AccelerationSettings out = accel;
    const bool all = value == "all";
    out.culling = out.worldCache = out.idField = all;
    out.prepass = false;
    if (all || value == "none") {
        accel = out;
        return true;
    }
    size_t start = 0;
    while (start <= value.size()) {
        const size_t comma = std::min(value.find(',', start), value.size());
        const std::string word = value.substr(start, comma - start);
        bool* flag = word == "culling"   ? &out.culling
                     : word == "cache"   ? &out.worldCache
                     : word == "id"      ? &out.idField
                     : word == "prepass" ? &out.prepass
                                         : nullptr;
        if (!flag) {
            error = fmt::format(
                "--accel '{}': unknown toggle '{}' (expected all, none or a comma-separated "
                "list of culling, cache, id, prepass)",
                value, word);
            return false;
        }
        *flag = true;
        start = comma + 1;
    }
    accel = out;
    return true;
}

}  // namespace penumbra::cli
