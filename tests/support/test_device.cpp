#include "support/test_device.h"

#include <cstdlib>
#include <cstring>

namespace penumbra::test {
namespace {
std::vector<rhi::Backend>& selected() {
    static std::vector<rhi::Backend> s;
    return s;
}
}  // namespace

void parseTestArgs(int& argc, char** argv) {
    auto select = [](const char* name) {
        rhi::Backend b;
        if (!rhi::parseBackend(name, b) || b == rhi::Backend::Auto) {
            std::fprintf(stderr, "unknown backend '%s' (use vulkan or gl)\n", name);
            std::exit(2);
        }
        selected() = {b};
    };
    if (const char* env = std::getenv("PENUMBRA_BACKEND"); env && *env) select(env);
    int out = 1;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--backend") == 0 && i + 1 < argc) {
            select(argv[++i]);
        } else if (std::strncmp(argv[i], "--backend=", 10) == 0) {
            select(argv[i] + 10);
        } else {
            argv[out++] = argv[i];
        }
    }
    argc = out;
    argv[argc] = nullptr;
}

std::vector<rhi::Backend> gpuBackends() {
    if (!selected().empty()) return selected();
    return {rhi::Backend::Vulkan, rhi::Backend::OpenGL};
}

std::string backendName(const testing::TestParamInfo<rhi::Backend>& info) {
    return info.param == rhi::Backend::Vulkan   ? "Vulkan"
           : info.param == rhi::Backend::OpenGL ? "OpenGL"
                                                : "Null";
}

std::unique_ptr<rhi::Device> createTestDevice(rhi::Backend backend, std::shared_ptr<LogCapture> log,
                                              bool validation) {
    rhi::DeviceDesc desc;
    desc.backend = backend;
    desc.headless = true;
    desc.validation = validation;
    desc.log = [log](rhi::LogSeverity s, std::string_view msg) {
        std::lock_guard lock(log->mutex);
        log->all.emplace_back(msg);
        if (s == rhi::LogSeverity::Error) {
            log->errors.emplace_back(msg);
            std::fprintf(stderr, "[rhi error] %.*s\n", int(msg.size()), msg.data());
        }
    };
    auto device = rhi::createDevice(desc);
    if (!device) {
        std::string why;
        for (auto& m : log->all) why += m + "\n";
        ADD_FAILURE() << "could not create a " << rhi::toString(backend) << " device:\n" << why;
    }
    return device;
}

void GpuTest::SetUp() {
    m_log = std::make_shared<LogCapture>();
    m_device = createTestDevice(GetParam(), m_log);
    ASSERT_NE(m_device, nullptr);
}

void GpuTest::TearDown() {
    if (m_device) m_device->waitIdle();
    std::lock_guard lock(m_log->mutex);
    EXPECT_TRUE(m_log->errors.empty())
        << m_log->errors.size()
        << " validation error(s), first: " << (m_log->errors.empty() ? "" : m_log->errors.front());
    m_device.reset();
}

void GpuTest::consumeExpectedErrors(size_t expected) {
    std::lock_guard lock(m_log->mutex);
    EXPECT_EQ(m_log->errors.size(), expected);
    m_log->errors.clear();
}

}  // namespace penumbra::test
