#include <cstdio>
#include <cstdlib>
#include <string>

#include "rhi/common/backend_factories.h"
#include "rhi/device.h"

namespace rhi {

namespace detail {
void logMessage(const LogCallback& log, LogSeverity severity, std::string_view message) {
    if (log) {
        log(severity, message);
        return;
    }
    static const char* kTags[] = {"debug", "info", "warning", "error"};
    std::fprintf(stderr, "[rhi %s] %.*s\n", kTags[int(severity)], int(message.size()), message.data());
}
}  // namespace detail

std::unique_ptr<Device> createDevice(const DeviceDesc& descIn) {
    DeviceDesc desc = descIn;
    if (desc.backend == Backend::Auto) {
        if (const char* env = std::getenv("PENUMBRA_BACKEND"); env && *env) {
            Backend b;
            if (parseBackend(env, b))
                desc.backend = b;
            else
                detail::logMessage(desc.log, LogSeverity::Warning,
                                   std::string("PENUMBRA_BACKEND='") + env +
                                       "' is not one of vulkan|gl|null|auto; using auto");
        }
    }

    // With validation on, count every error-severity message the backend reports (Vulkan
    // validation layer, GL debug output) together with the wrapper's own reports.
    auto errorCounter = std::make_shared<uint64_t>(0);
    LogCallback userLog = desc.log;
    if (desc.validation) {
        desc.log = [userLog, errorCounter](LogSeverity s, std::string_view msg) {
            if (s == LogSeverity::Error) ++*errorCounter;
            detail::logMessage(userLog, s, msg);
        };
    }

    std::unique_ptr<Device> device;
    switch (desc.backend) {
        case Backend::Vulkan:
            device = detail::createVulkanDevice(desc);
            break;
        case Backend::OpenGL:
            device = detail::createOpenGLDevice(desc);
            break;
        case Backend::Null:
            device = detail::createNullDevice(desc);
            break;
        case Backend::Auto:
            device = detail::createVulkanDevice(desc);
            if (!device) {
                detail::logMessage(desc.log, LogSeverity::Info, "Vulkan unavailable, trying OpenGL");
                device = detail::createOpenGLDevice(desc);
            }
            break;
    }
    if (!device) return nullptr;
    if (desc.validation) return detail::createValidationDevice(std::move(device), desc.log, errorCounter);
    return device;
}

uint64_t validationErrorCount(const Device& device) { return detail::validationErrorCountOf(device); }

}  // namespace rhi
