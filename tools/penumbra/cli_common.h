// Checks shared by the penumbra subcommands, so that every command validates its inputs, outputs,
// backend and image size the same way and before any work:
//   - input files: exist, are regular files and can be opened (a folder is named as a folder);
//   - outputs: engine/core/output_file.h (temporary file + rename, all or nothing); images: PNG only;
//   - backend: --backend / $PENUMBRA_BACKEND; the null backend (executes nothing) is refused;
//   - image size: --width/--height are 1 .. the device's maximum 2D texture size.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "engine/core/output_file.h"
#include "engine/image/image.h"
#include "engine/scene/scene.h"
#include "rhi/device.h"

namespace penumbra::cli {

// Adds "--backend" (vulkan | vk | gl | opengl | auto; "null" is refused with the reason).
CLI::Option* addBackendOption(CLI::App* cmd, std::string& backend);

// Adds --width or --height: a whole number of pixels >= 1; the upper bound is the device's
// maximum 2D texture size, checked by checkImageSize() once the device is open.
CLI::Option* addSizeOption(CLI::App* cmd, const std::string& name, uint32_t& value, const std::string& help);

// The backend a command will use: --backend if given, else $PENUMBRA_BACKEND, else auto. Refuses
// the null backend, which records commands but executes none (the image would be blank):
// `command` names the subcommand in the message.
bool chooseBackend(const std::string& flag, const char* command, rhi::Backend& out, std::string& error);
// The same check on an opened device (in case the backend was chosen some other way).
bool refuseNullDevice(const rhi::Device& device, const char* command, std::string& error);

// Width and height against the device's maximum 2D texture size; `source` says where the values
// come from (e.g. "--width/--height" or "the scene's render.width/height").
bool checkImageSize(uint32_t width, uint32_t height, const rhi::Device& device, const std::string& source,
                    std::string& error);

// An input file that must exist and be readable; `what` names what it should be ("scene file").
bool checkInputFile(const std::string& path, const std::string& what, std::string& error);

// Image outputs are PNG: refuses other extensions (".jpg" would silently get PNG data).
bool checkPngPath(const std::string& path, const std::string& option, std::string& error);

// Writes `image` as PNG to the temporary file of the output `path` (added to `outputs` before).
bool writePngOutput(OutputFiles& outputs, const std::string& path, const ImageRGBA8& image,
                    std::string& error);

// The validation step of every command: each non-empty path is added to `outputs` (folders
// created, a temporary file next to each destination). Logs the error and returns false.
bool prepareOutputs(OutputFiles& outputs, const std::vector<std::string>& paths, const char* command);

// `--backend` of the benchmarks: vulkan (vk), gl (opengl) or both (Vulkan, then OpenGL).
CLI::Option* addBenchBackendOption(CLI::App* cmd, std::string& value);
// The backends that value names, in run order (both: Vulkan, then OpenGL); false when it names none.
bool benchBackends(const std::string& value, std::vector<rhi::Backend>& out);

// `--accel all|none|LIST` (render, bench trace): LIST is a comma-separated subset of culling, cache,
// id, prepass and turns exactly those on; all = the four; none = the unaccelerated baseline.
CLI::Option* addAccelOption(CLI::App* cmd, std::string& value);
// Applies an --accel value to the toggles of `accel` (cache sizes unchanged); false with `error`
// naming the unknown word. An empty value changes nothing (the scene's render.acceleration).
bool applyAccelOption(const std::string& value, scene::AccelerationSettings& accel, std::string& error);

// The processed-asset cache folder: $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra, else
// ~/.cache/penumbra (empty when none of them is set).
std::string defaultCacheDir();

// The median of the finite values of `v` (NaN when there is none).
double median(std::vector<double> v);

// Machine facts for benchmark reports: "1.33 / 1.72 / 2.40 (1 / 5 / 15 min)" from /proc/loadavg
// ("unknown" when unreadable), the CPU model name, and the current time as "YYYY-MM-DD HH:MM UTC".
std::string loadAverage();
std::string cpuModel();
std::string utcNow();

}  // namespace penumbra::cli
