// Unit tests of the validation wrapper over the null device: every check is provoked once (message
// and error count asserted) next to the matching correct usage, which must report nothing.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "rhi/device.h"
#include "rhi/null/null_device.h"

namespace {

using rhi::Access;
using rhi::BindingType;
using rhi::BufferUsage;
using rhi::TextureUsage;

rhi::ShaderBinding binding(const char* name, uint32_t set, uint32_t b, BindingType type, bool writes = false,
                           rhi::TextureDimension dim = rhi::TextureDimension::Tex2D) {
    rhi::ShaderBinding sb;
    sb.name = name;
    sb.set = set;
    sb.binding = b;
    sb.type = type;
    sb.writes = writes;
    sb.textureDimension = dim;
    return sb;
}

// Compute shader: writes a storage buffer and a storage image, samples a texture; set 1 has a UBO.
const rhi::ShaderBinding kComputeBindings[] = {
    binding("results", 0, 0, BindingType::StorageBuffer, true),
    binding("outImage", 0, 1, BindingType::StorageTexture, true),
    binding("inputTex", 0, 2, BindingType::SampledTexture),
    binding("params", 1, 0, BindingType::UniformBuffer),
};
// Vertex + fragment shaders: camera UBO (both stages), albedo texture, read-only light list.
const rhi::ShaderBinding kVertexBindings[] = {
    binding("camera", 0, 0, BindingType::UniformBuffer),
};
const rhi::ShaderBinding kFragmentBindings[] = {
    binding("camera", 0, 0, BindingType::UniformBuffer),
    binding("albedo", 0, 1, BindingType::SampledTexture),
    binding("lights", 1, 0, BindingType::ReadOnlyStorageBuffer),
};

bool contains(const std::string& haystack, const std::string& needle) {
    return haystack.find(needle) != std::string::npos;
}

class ValidationTest : public testing::Test {
protected:
    void SetUp() override {
        m_device = makeDevice();
        ASSERT_NE(m_device, nullptr);
    }

    void TearDown() override {
        if (!m_device) return;
        m_device->waitIdle();
        EXPECT_EQ(rhi::validationErrorCount(*m_device), m_expected)
            << "unexpected errors, last: " << lastError();
        m_device.reset();
    }

    std::unique_ptr<rhi::Device> makeDevice() {
        rhi::DeviceDesc desc;
        desc.backend = rhi::Backend::Null;
        desc.validation = true;
        desc.log = [this](rhi::LogSeverity s, std::string_view msg) {
            if (s == rhi::LogSeverity::Error) m_errors.emplace_back(msg);
        };
        return rhi::createDevice(desc);
    }

    rhi::Device& dev() { return *m_device; }
    std::string lastError() const { return m_errors.empty() ? std::string() : m_errors.back(); }

    // Exactly one new error, whose text contains `text`.
    void expectError(const std::string& text) {
        ++m_expected;
        EXPECT_EQ(rhi::validationErrorCount(dev()), m_expected) << "last: " << lastError();
        EXPECT_EQ(m_errors.size(), m_expected);
        EXPECT_TRUE(contains(lastError(), text)) << "expected '" << text << "' in '" << lastError() << "'";
        EXPECT_EQ(lastError().rfind("validation: ", 0), 0u) << lastError();
        m_expected = rhi::validationErrorCount(dev());
    }
    // Exactly one new error with exactly this text.
    void expectExactError(const std::string& text) {
        ++m_expected;
        EXPECT_EQ(rhi::validationErrorCount(dev()), m_expected);
        EXPECT_EQ(lastError(), text);
        m_expected = rhi::validationErrorCount(dev());
    }
    void expectNoNewErrors() {
        EXPECT_EQ(rhi::validationErrorCount(dev()), m_expected) << "last: " << lastError();
    }

    // --- object helpers ----------------------------------------------------------------------------
    rhi::BufferHandle makeBuffer(const char* name, uint64_t size,
                                 BufferUsage usage = BufferUsage::Storage | BufferUsage::Uniform |
                                                     BufferUsage::CopySrc | BufferUsage::CopyDst) {
        rhi::BufferDesc d;
        d.size = size;
        d.usage = usage;
        d.debugName = name;
        return dev().createBuffer(d);
    }
    rhi::TextureHandle makeTexture(const char* name, rhi::Format format = rhi::Format::RGBA8_UNORM,
                                   TextureUsage usage = TextureUsage::Sampled | TextureUsage::Storage |
                                                        TextureUsage::CopyDst,
                                   uint32_t size = 16, uint32_t mips = 1) {
        rhi::TextureDesc d;
        d.format = format;
        d.width = d.height = size;
        d.mipLevels = mips;
        d.usage = usage;
        d.debugName = name;
        return dev().createTexture(d);
    }
    rhi::ShaderHandle makeShader(rhi::ShaderStage stage, std::span<const rhi::ShaderBinding> bindings,
                                 uint32_t pushConstants, const char* name) {
        rhi::ShaderDesc d;
        d.stage = stage;
        d.bindings = bindings;
        d.pushConstantSize = pushConstants;
        d.workgroupSize = stage == rhi::ShaderStage::Compute ? std::array<uint32_t, 3>{8, 8, 1}
                                                             : std::array<uint32_t, 3>{1, 1, 1};
        d.debugName = name;
        return dev().createShader(d);
    }
    rhi::PipelineHandle makeComputePipeline() {
        rhi::ComputePipelineDesc d;
        d.shader = makeShader(rhi::ShaderStage::Compute, kComputeBindings, 16, "cs");
        d.debugName = "compute";
        return dev().createComputePipeline(d);
    }
    rhi::PipelineHandle makeGraphicsPipeline(std::vector<rhi::Format> colors = {rhi::Format::RGBA8_UNORM},
                                             rhi::Format depth = rhi::Format::D32_FLOAT) {
        rhi::GraphicsPipelineDesc d;
        d.vertexShader = makeShader(rhi::ShaderStage::Vertex, kVertexBindings, 8, "vs");
        d.fragmentShader = makeShader(rhi::ShaderStage::Fragment, kFragmentBindings, 0, "fs");
        d.colorFormats = std::move(colors);
        d.depthFormat = depth;
        d.debugName = "raster";
        return dev().createGraphicsPipeline(d);
    }
    rhi::SamplerHandle makeSampler() {
        rhi::SamplerDesc d;
        d.debugName = "linear";
        return dev().createSampler(d);
    }

    // Compute resources bound in both sets, all valid.
    struct ComputeSetup {
        rhi::PipelineHandle pipeline;
        rhi::BufferHandle results, params;
        rhi::TextureHandle outImage, input;
        rhi::SamplerHandle sampler;
        rhi::BindGroupHandle set0, set1;
    };
    ComputeSetup makeComputeSetup(const char* inputName = "input") {
        ComputeSetup s;
        s.pipeline = makeComputePipeline();
        s.results = makeBuffer("results", 256);
        s.params = makeBuffer("params", 64);
        s.outImage = makeTexture("outImage");
        s.input = makeTexture(inputName, rhi::Format::R32_FLOAT);
        s.sampler = makeSampler();
        rhi::BindGroupDesc g0;
        g0.pipeline = s.pipeline;
        g0.set = 0;
        g0.entries = {rhi::BindGroupEntry::makeBuffer(0, s.results),
                      rhi::BindGroupEntry::makeStorage(1, s.outImage),
                      rhi::BindGroupEntry::makeSampled(2, s.input, s.sampler)};
        g0.debugName = "compute.set0";
        s.set0 = dev().createBindGroup(g0);
        rhi::BindGroupDesc g1;
        g1.pipeline = s.pipeline;
        g1.set = 1;
        g1.entries = {rhi::BindGroupEntry::makeBuffer(0, s.params)};
        g1.debugName = "compute.set1";
        s.set1 = dev().createBindGroup(g1);
        return s;
    }
    // Puts the compute setup's textures in the states a dispatch needs.
    void prepareCompute(rhi::CommandList& list, const ComputeSetup& s) {
        const rhi::Barrier barriers[] = {rhi::Barrier::tex(s.outImage, Access::None, Access::ShaderWrite),
                                         rhi::Barrier::tex(s.input, Access::None, Access::ShaderSampled)};
        list.barrier(barriers);
        list.bindPipeline(s.pipeline);
        list.bindGroup(0, s.set0);
        list.bindGroup(1, s.set1);
    }

    // Graphics resources, all valid.
    struct GraphicsSetup {
        rhi::PipelineHandle pipeline;
        rhi::BufferHandle camera, lights;
        rhi::TextureHandle albedo, color, depth;
        rhi::SamplerHandle sampler;
        rhi::BindGroupHandle set0, set1;
    };
    GraphicsSetup makeGraphicsSetup() {
        GraphicsSetup s;
        s.pipeline = makeGraphicsPipeline();
        s.camera = makeBuffer("camera", 256);
        s.lights = makeBuffer("lights", 1024);
        s.albedo = makeTexture("albedo");
        s.color =
            makeTexture("color", rhi::Format::RGBA8_UNORM, TextureUsage::ColorTarget | TextureUsage::Sampled);
        s.depth =
            makeTexture("depth", rhi::Format::D32_FLOAT, TextureUsage::DepthTarget | TextureUsage::Sampled);
        s.sampler = makeSampler();
        rhi::BindGroupDesc g0;
        g0.pipeline = s.pipeline;
        g0.entries = {rhi::BindGroupEntry::makeBuffer(0, s.camera),
                      rhi::BindGroupEntry::makeSampled(1, s.albedo, s.sampler)};
        g0.debugName = "raster.set0";
        s.set0 = dev().createBindGroup(g0);
        rhi::BindGroupDesc g1;
        g1.pipeline = s.pipeline;
        g1.set = 1;
        g1.entries = {rhi::BindGroupEntry::makeBuffer(0, s.lights)};
        g1.debugName = "raster.set1";
        s.set1 = dev().createBindGroup(g1);
        return s;
    }
    rhi::RenderPassDesc passFor(const GraphicsSetup& s) {
        rhi::RenderPassDesc rp;
        rp.colorAttachments.resize(1);
        rp.colorAttachments[0].texture = s.color;
        rp.depthAttachment.texture = s.depth;
        rp.debugName = "main";
        return rp;
    }
    void prepareGraphics(rhi::CommandList& list, const GraphicsSetup& s) {
        const rhi::Barrier barriers[] = {rhi::Barrier::tex(s.albedo, Access::None, Access::ShaderSampled),
                                         rhi::Barrier::tex(s.color, Access::None, Access::ColorTarget),
                                         rhi::Barrier::tex(s.depth, Access::None, Access::DepthTargetWrite)};
        list.barrier(barriers);
    }
    void bindGraphics(rhi::CommandList& list, const GraphicsSetup& s) {
        list.bindPipeline(s.pipeline);
        list.bindGroup(0, s.set0);
        list.bindGroup(1, s.set1);
    }

    std::unique_ptr<rhi::Device> m_device;
    std::vector<std::string> m_errors;
    uint64_t m_expected = 0;
};

// --- handles ------------------------------------------------------------------------------------------

TEST_F(ValidationTest, StaleHandleIsReportedAndDropped) {
    rhi::BufferHandle a = makeBuffer("a", 64);
    uint32_t v = 1;
    dev().writeBuffer(a, 0, &v, 4);
    expectNoNewErrors();
    dev().destroy(a);
    dev().writeBuffer(a, 0, &v, 4);
    expectError("validation: writeBuffer: stale buffer (dst) handle");
    EXPECT_TRUE(contains(lastError(), "('a'): it was destroyed")) << lastError();

    // Slot reused by a new object: the old handle's generation no longer matches.
    dev().submit(dev().beginCommandList());
    rhi::BufferHandle b = makeBuffer("b", 64);
    ASSERT_EQ(b.index(), a.index());
    uint32_t out = 0;
    EXPECT_FALSE(dev().readBuffer(a, 0, 4, &out));
    expectError("validation: readBuffer: stale buffer (src) handle");
    EXPECT_TRUE(contains(lastError(), "slot has been reused")) << lastError();
    EXPECT_TRUE(dev().readBuffer(b, 0, 4, &out));
    expectNoNewErrors();
}

TEST_F(ValidationTest, InvalidHandleIsReported) {
    rhi::CommandList& list = dev().beginCommandList();
    list.bindPipeline(rhi::PipelineHandle{});
    expectError("validation: bindPipeline: invalid (null) pipeline (pipeline) handle");
    list.fillBuffer(rhi::BufferHandle{}, 0, 4, 0);
    expectError("validation: fillBuffer: invalid (null) buffer (dst) handle");
    rhi::ComputePipelineDesc pd;
    EXPECT_FALSE(dev().createComputePipeline(pd).isValid());
    expectError("validation: createComputePipeline: invalid (null) shader (shader) handle");
    dev().submit(list);
    expectNoNewErrors();
    EXPECT_TRUE(rhi::null::recordedCommands(dev()).empty());
}

TEST_F(ValidationTest, HandleFromAnotherDeviceIsReported) {
    std::unique_ptr<rhi::Device> other = makeDevice();
    rhi::BufferDesc d;
    d.size = 16;
    d.debugName = "other";
    other->createBuffer(d);
    rhi::BufferHandle foreign = other->createBuffer(d);
    rhi::BufferHandle mine = makeBuffer("mine", 16);
    ASSERT_NE(foreign.index(), mine.index());
    uint32_t v = 0;
    dev().writeBuffer(foreign, 0, &v, 4);
    expectError("validation: writeBuffer: buffer (dst) handle");
    EXPECT_TRUE(contains(lastError(), "was not created by this device")) << lastError();
    dev().writeBuffer(mine, 0, &v, 4);
    other.reset();
    expectNoNewErrors();
}

TEST_F(ValidationTest, DoubleDestroyIsReported) {
    rhi::TextureHandle t = makeTexture("once");
    dev().destroy(t);
    expectNoNewErrors();
    dev().destroy(t);
    expectError("validation: destroy: texture");
    EXPECT_TRUE(contains(lastError(), "('once') was already destroyed (double destroy)")) << lastError();
    dev().destroy(rhi::SamplerHandle{});
    expectError("validation: destroy: invalid (null) sampler handle");
}

// --- descriptions -------------------------------------------------------------------------------------

TEST_F(ValidationTest, InvalidResourceDescsAreRejected) {
    rhi::BufferDesc bd;
    bd.debugName = "empty";
    EXPECT_FALSE(dev().createBuffer(bd).isValid());
    expectExactError("validation: createBuffer: buffer 'empty' has size 0");

    rhi::TextureDesc td;
    td.debugName = "t";
    td.width = 0;
    EXPECT_FALSE(dev().createTexture(td).isValid());
    expectExactError("validation: createTexture: texture 't' has a zero-sized extent (0x1x1)");

    td.width = td.height = 16;
    td.mipLevels = 6;
    EXPECT_FALSE(dev().createTexture(td).isValid());
    expectExactError("validation: createTexture: texture 't' asks for 6 mip levels; its full chain has 5");

    td.mipLevels = 1;
    td.depthOrLayers = 4;
    EXPECT_FALSE(dev().createTexture(td).isValid());
    expectError("validation: createTexture: texture 't' is a Tex2D with depthOrLayers = 4");

    td.depthOrLayers = 1;
    td.format = rhi::Format::D32_FLOAT;
    td.usage = TextureUsage::Storage | TextureUsage::DepthTarget;
    EXPECT_FALSE(dev().createTexture(td).isValid());
    expectError("validation: createTexture: texture 't' has depth format D32_FLOAT and Storage usage");

    // The same descriptions, corrected.
    bd.size = 4;
    EXPECT_TRUE(dev().createBuffer(bd).isValid());
    td.usage = TextureUsage::Sampled | TextureUsage::DepthTarget;
    td.mipLevels = 5;
    EXPECT_TRUE(dev().createTexture(td).isValid());
    td.dimension = rhi::TextureDimension::Tex2DArray;
    td.format = rhi::Format::RGBA16_FLOAT;
    td.usage = TextureUsage::Storage;
    td.depthOrLayers = 4;
    EXPECT_TRUE(dev().createTexture(td).isValid());
    td.dimension = rhi::TextureDimension::Tex3D;
    td.depthOrLayers = 64;
    td.mipLevels = 7;  // full chain of 16x16x64
    EXPECT_TRUE(dev().createTexture(td).isValid());
    expectNoNewErrors();
}

TEST_F(ValidationTest, UpdateBufferSizesAreChecked) {
    rhi::BufferHandle b = makeBuffer("b", 1 << 17);
    std::vector<uint8_t> data(65540);
    rhi::CommandList& list = dev().beginCommandList();
    list.updateBuffer(b, 0, data.data(), 0);
    expectError("validation: updateBuffer: size 0 at offset 0 is invalid");
    list.updateBuffer(b, 0, data.data(), 65540);
    expectError("validation: updateBuffer: size 65540 at offset 0 is invalid");
    list.updateBuffer(b, 0, data.data(), 6);
    expectError("validation: updateBuffer: size 6 at offset 0 is invalid");
    list.updateBuffer(b, 0, data.data(), 65536);
    list.updateBuffer(b, 4, data.data(), 8);
    dev().submit(list);
    expectNoNewErrors();
    EXPECT_EQ(rhi::null::recordedCommands(dev()).size(), 2u);
}

TEST_F(ValidationTest, RangesAreCheckedWithoutOverflow) {
    rhi::BufferHandle a = makeBuffer("a", 64);
    rhi::BufferHandle b = makeBuffer("b", 64);
    const uint64_t huge = ~uint64_t(0) - 3;
    std::vector<uint8_t> bytes(64);

    dev().writeBuffer(a, 60, bytes.data(), 8);
    expectExactError("validation: writeBuffer: range [60, +8) exceeds buffer 'a' of 64 bytes");
    dev().writeBuffer(a, huge, bytes.data(), 8);  // offset + size wraps around
    expectError("validation: writeBuffer: range [");
    EXPECT_FALSE(dev().readBuffer(a, 8, huge, bytes.data()));
    expectError("validation: readBuffer: range [8, +");

    rhi::CommandList& list = dev().beginCommandList();
    list.copyBuffer(a, 0, b, 32, 40);
    expectExactError("validation: copyBuffer: range [32, +40) exceeds buffer 'b' of 64 bytes");
    list.fillBuffer(b, 64, 4, 0);
    expectExactError("validation: fillBuffer: range [64, +4) exceeds buffer 'b' of 64 bytes");
    list.fillBuffer(b, huge, 8, 0);
    expectError("validation: fillBuffer: range [");

    // Bind-group buffer ranges.
    rhi::PipelineHandle p = makeComputePipeline();
    rhi::BindGroupDesc g;
    g.pipeline = p;
    g.set = 1;
    g.entries = {rhi::BindGroupEntry::makeBuffer(0, a, 32, 64)};
    g.debugName = "g";
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectError(
        "validation: createBindGroup: bind group 'g' (pipeline 'compute', set 1) binding 0 ('params') range");

    // In range, up to the last byte.
    dev().writeBuffer(a, 56, bytes.data(), 8);
    EXPECT_TRUE(dev().readBuffer(a, 0, 64, bytes.data()));
    list.copyBuffer(a, 0, b, 0, 64);
    g.entries = {rhi::BindGroupEntry::makeBuffer(0, a, 32, 32)};
    EXPECT_TRUE(dev().createBindGroup(g).isValid());
    g.entries = {rhi::BindGroupEntry::makeBuffer(0, a, 32)};
    EXPECT_TRUE(dev().createBindGroup(g).isValid());
    dev().submit(list);
    expectNoNewErrors();
}

// --- shaders and pipelines ----------------------------------------------------------------------------

TEST_F(ValidationTest, PushConstantSizeOfShadersIsLimited) {
    EXPECT_FALSE(makeShader(rhi::ShaderStage::Compute, {}, 132, "big").isValid());
    expectExactError(
        "validation: createShader: shader 'big' declares 132 bytes of push constants, more than "
        "kMaxPushConstantSize (128)");
    EXPECT_TRUE(makeShader(rhi::ShaderStage::Compute, {}, 128, "fits").isValid());
    expectNoNewErrors();
}

TEST_F(ValidationTest, PipelineDescsAreChecked) {
    rhi::ShaderHandle cs = makeShader(rhi::ShaderStage::Compute, kComputeBindings, 0, "cs");
    rhi::ShaderHandle vs = makeShader(rhi::ShaderStage::Vertex, kVertexBindings, 0, "vs");
    rhi::ShaderHandle fs = makeShader(rhi::ShaderStage::Fragment, kFragmentBindings, 0, "fs");

    rhi::GraphicsPipelineDesc gd;
    gd.vertexShader = cs;
    gd.fragmentShader = fs;
    gd.colorFormats = {rhi::Format::RGBA8_UNORM};
    gd.debugName = "g";
    EXPECT_FALSE(dev().createGraphicsPipeline(gd).isValid());
    expectExactError(
        "validation: createGraphicsPipeline: pipeline 'g' is given compute shader 'cs' as its vertex shader");

    rhi::ComputePipelineDesc cd;
    cd.shader = vs;
    cd.debugName = "c";
    EXPECT_FALSE(dev().createComputePipeline(cd).isValid());
    expectExactError(
        "validation: createComputePipeline: pipeline 'c' is given vertex shader 'vs'; a compute pipeline "
        "needs a "
        "compute shader");

    gd.vertexShader = vs;
    gd.colorFormats.assign(rhi::kMaxColorTargets + 1, rhi::Format::RGBA8_UNORM);
    EXPECT_FALSE(dev().createGraphicsPipeline(gd).isValid());
    expectExactError(
        "validation: createGraphicsPipeline: pipeline 'g' has 9 colour formats, more than kMaxColorTargets "
        "(8)");

    gd.colorFormats = {rhi::Format::RGBA8_UNORM, rhi::Format::RGBA16_FLOAT};
    gd.blend.resize(1);
    EXPECT_FALSE(dev().createGraphicsPipeline(gd).isValid());
    expectExactError(
        "validation: createGraphicsPipeline: pipeline 'g' has 1 blend states for 2 colour targets (need none "
        "or one "
        "per target)");

    gd.blend.resize(2);
    EXPECT_TRUE(dev().createGraphicsPipeline(gd).isValid());
    gd.blend.clear();
    EXPECT_TRUE(dev().createGraphicsPipeline(gd).isValid());
    cd.shader = cs;
    EXPECT_TRUE(dev().createComputePipeline(cd).isValid());
    expectNoNewErrors();
}

// --- bind groups --------------------------------------------------------------------------------------

TEST_F(ValidationTest, BindGroupsAreCheckedAgainstReflection) {
    rhi::PipelineHandle p = makeComputePipeline();
    rhi::BufferHandle storage = makeBuffer("storage", 256);
    rhi::BufferHandle vertexOnly = makeBuffer("vertexOnly", 256, BufferUsage::Vertex);
    rhi::TextureHandle image =
        makeTexture("image", rhi::Format::RGBA8_UNORM, TextureUsage::Storage | TextureUsage::Sampled, 16, 2);
    rhi::TextureHandle sampledOnly =
        makeTexture("sampledOnly", rhi::Format::RGBA8_UNORM, TextureUsage::Sampled);
    rhi::TextureHandle storageOnly =
        makeTexture("storageOnly", rhi::Format::R32_FLOAT, TextureUsage::Storage);
    rhi::TextureDesc ad;
    ad.dimension = rhi::TextureDimension::Tex2DArray;
    ad.width = ad.height = 16;
    ad.depthOrLayers = 2;
    ad.debugName = "array";
    rhi::TextureHandle array = dev().createTexture(ad);
    rhi::SamplerHandle sampler = makeSampler();
    expectNoNewErrors();

    rhi::BindGroupDesc g;
    g.pipeline = p;
    g.debugName = "g";
    auto valid = [&] {
        return std::vector<rhi::BindGroupEntry>{rhi::BindGroupEntry::makeBuffer(0, storage),
                                                rhi::BindGroupEntry::makeStorage(1, image),
                                                rhi::BindGroupEntry::makeSampled(2, image, sampler)};
    };
    const std::string where = "validation: createBindGroup: bind group 'g' (pipeline 'compute', set 0) ";

    g.set = rhi::kMaxBindGroups;
    g.entries = valid();
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError("validation: createBindGroup: bind group 'g' has set 4, beyond kMaxBindGroups (4)");
    g.set = 0;

    g.entries.push_back(rhi::BindGroupEntry::makeBuffer(7, storage));
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(where + "binding 7 is not declared by the pipeline's shaders");

    g.entries = valid();
    g.entries.push_back(rhi::BindGroupEntry::makeBuffer(0, storage));
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(where + "binding 0 ('results') appears twice");

    g.entries = valid();
    g.entries.pop_back();
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(where + "has no entry for binding 2 ('inputTex', SampledTexture)");

    g.entries = valid();
    g.entries[0] = rhi::BindGroupEntry::makeStorage(0, image);
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(where +
                     "binding 0 ('results') is a StorageBuffer binding but the entry gives a texture");

    g.entries = valid();
    g.entries[1] = rhi::BindGroupEntry::makeBuffer(1, storage);
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(where +
                     "binding 1 ('outImage') is a StorageTexture binding but the entry gives a buffer");

    g.entries = valid();
    g.entries[0] = rhi::BindGroupEntry::makeBuffer(0, vertexOnly);
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(
        where +
        "binding 0 ('results') binds buffer 'vertexOnly' as a StorageBuffer but it was created without "
        "Storage usage");

    g.entries = valid();
    g.entries[2] = rhi::BindGroupEntry::makeSampled(2, storageOnly, sampler);
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(
        where +
        "binding 2 ('inputTex') samples texture 'storageOnly' but it was created without Sampled usage");

    g.entries = valid();
    g.entries[1] = rhi::BindGroupEntry::makeStorage(1, sampledOnly);
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(
        where +
        "binding 1 ('outImage') binds texture 'sampledOnly' as a storage image but it was created "
        "without Storage usage");

    g.entries = valid();
    g.entries[2] = rhi::BindGroupEntry::makeSampled(2, image, rhi::SamplerHandle{});
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(where +
                     "binding 2 ('inputTex') is a SampledTexture binding but the entry has no sampler");

    g.entries = valid();
    g.entries[1] = rhi::BindGroupEntry::makeStorage(1, image, 2);
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(where + "binding 1 ('outImage') binds mip 2 of texture 'image', which has 2 mip levels");

    g.entries = valid();
    g.entries[2] = rhi::BindGroupEntry::makeSampled(2, array, sampler);
    EXPECT_FALSE(dev().createBindGroup(g).isValid());
    expectExactError(where +
                     "binding 2 ('inputTex') expects a Tex2D texture but texture 'array' is Tex2DArray");

    g.entries = valid();
    EXPECT_TRUE(dev().createBindGroup(g).isValid());
    g.entries[1] = rhi::BindGroupEntry::makeStorage(1, image, 1);
    EXPECT_TRUE(dev().createBindGroup(g).isValid());
    expectNoNewErrors();
}

TEST_F(ValidationTest, BindGroupSetIndexIsChecked) {
    ComputeSetup s = makeComputeSetup();
    rhi::CommandList& list = dev().beginCommandList();
    list.bindPipeline(s.pipeline);
    list.bindGroup(4, s.set0);
    expectExactError("validation: bindGroup: out-of-range bind: set 4 >= kMaxBindGroups (4)");
    list.bindGroup(0, s.set1);
    expectExactError(
        "validation: bindGroup: bind group 'compute.set1' was created for set 1 but is bound to set 0");
    list.bindGroup(0, s.set0);
    list.bindGroup(1, s.set1);
    dev().submit(list);
    expectNoNewErrors();
}

// --- command order ------------------------------------------------------------------------------------

TEST_F(ValidationTest, DispatchNeedsAComputePipelineOutsideRenderPasses) {
    ComputeSetup c = makeComputeSetup();
    GraphicsSetup g = makeGraphicsSetup();
    rhi::CommandList& list = dev().beginCommandList();
    list.dispatch(1);
    expectExactError("validation: dispatch: no compute pipeline is bound");
    list.bindPipeline(g.pipeline);
    list.dispatch(1);
    expectExactError("validation: dispatch: the bound pipeline 'raster' is not a compute pipeline");

    prepareCompute(list, c);
    list.dispatch(70000);
    expectExactError("validation: dispatch: groups 70000x1x1 exceed the device limit of 65535x65535x65535");
    list.dispatch(4, 4);
    expectNoNewErrors();

    prepareGraphics(list, g);
    list.beginRenderPass(passFor(g));
    list.dispatch(1);
    expectExactError("validation: dispatch: dispatch inside a render pass");
    list.endRenderPass();
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, DrawNeedsARenderPassAndAGraphicsPipeline) {
    ComputeSetup c = makeComputeSetup();
    GraphicsSetup g = makeGraphicsSetup();
    rhi::CommandList& list = dev().beginCommandList();
    prepareGraphics(list, g);
    bindGraphics(list, g);
    list.draw(3);
    expectExactError("validation: draw: draw outside a render pass");

    list.beginRenderPass(passFor(g));
    list.bindPipeline(c.pipeline);
    list.draw(3);
    expectExactError("validation: draw: the bound pipeline 'compute' is not a graphics pipeline");
    bindGraphics(list, g);
    list.draw(3);
    expectNoNewErrors();
    list.drawIndexed(3);
    expectExactError("validation: drawIndexed: no index buffer is bound");
    list.endRenderPass();
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, RenderPassAttachmentsMustMatchThePipeline) {
    GraphicsSetup g = makeGraphicsSetup();
    rhi::TextureHandle hdr = makeTexture("hdr", rhi::Format::RGBA16_FLOAT, TextureUsage::ColorTarget);
    rhi::CommandList& list = dev().beginCommandList();
    prepareGraphics(list, g);
    list.barrier(rhi::Barrier::tex(hdr, Access::None, Access::ColorTarget));

    rhi::RenderPassDesc rp = passFor(g);
    rp.colorAttachments[0].texture = hdr;
    list.beginRenderPass(rp);
    bindGraphics(list, g);
    list.draw(3);
    expectExactError(
        "validation: draw: pipeline 'raster' renders to [RGBA8_UNORM] depth D32_FLOAT but the render pass "
        "attachments are [RGBA16_FLOAT] depth D32_FLOAT");
    list.endRenderPass();

    rp = passFor(g);
    rp.depthAttachment.texture = {};
    list.beginRenderPass(rp);
    list.draw(3);
    expectExactError(
        "validation: draw: pipeline 'raster' renders to [RGBA8_UNORM] depth D32_FLOAT but the render pass "
        "attachments are [RGBA8_UNORM] depth Undefined");
    list.endRenderPass();

    list.beginRenderPass(passFor(g));
    list.draw(3);
    list.endRenderPass();
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, RenderPassesMustNotNestAndMustBeClosed) {
    GraphicsSetup g = makeGraphicsSetup();
    rhi::CommandList& list = dev().beginCommandList();
    prepareGraphics(list, g);
    list.endRenderPass();
    expectExactError(
        "validation: endRenderPass: no render pass is open (endRenderPass without beginRenderPass)");
    list.beginRenderPass(passFor(g));
    list.beginRenderPass(passFor(g));
    expectExactError(
        "validation: beginRenderPass: nested render pass: render pass 'main' begins while another render "
        "pass is open");
    list.endRenderPass();
    expectNoNewErrors();

    list.beginRenderPass(passFor(g));
    dev().submit(list);
    expectExactError(
        "validation: submit: the command list still has an open render pass (missing endRenderPass)");
    // The wrapper closed the pass for the backend.
    const auto& cmds = rhi::null::recordedCommands(dev());
    ASSERT_FALSE(cmds.empty());
    EXPECT_EQ(cmds.back().kind, rhi::null::RecordedCommand::Kind::EndRenderPass);
}

TEST_F(ValidationTest, DebugGroupsMustBalance) {
    rhi::CommandList& list = dev().beginCommandList();
    list.popDebugGroup();
    expectExactError(
        "validation: popDebugGroup: no debug group is open (popDebugGroup without pushDebugGroup)");
    list.pushDebugGroup("a");
    list.pushDebugGroup("b");
    list.popDebugGroup();
    dev().submit(list);
    expectExactError(
        "validation: submit: the command list has 1 unbalanced pushDebugGroup (missing popDebugGroup)");

    rhi::CommandList& ok = dev().beginCommandList();
    ok.pushDebugGroup("a");
    ok.popDebugGroup();
    dev().submit(ok);
    expectNoNewErrors();
}

TEST_F(ValidationTest, PushConstantsAreLimitedByThePipeline) {
    ComputeSetup c = makeComputeSetup();  // 16 bytes of push constants
    uint8_t data[256] = {};
    rhi::CommandList& list = dev().beginCommandList();
    list.pushConstants(data, 4);
    expectExactError("validation: pushConstants: no pipeline is bound");
    list.bindPipeline(c.pipeline);
    list.pushConstants(data, 20);
    expectExactError(
        "validation: pushConstants: range [0, +20) exceeds the 16 bytes of push constants of pipeline "
        "'compute'");
    list.pushConstants(data, 132);
    expectExactError("validation: pushConstants: range [0, +132) exceeds kMaxPushConstantSize (128)");
    list.pushConstants(data, 8, 8);
    list.pushConstants(data, 16);
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, DeclaredSetsMustBeBound) {
    ComputeSetup c = makeComputeSetup();
    rhi::CommandList& list = dev().beginCommandList();
    prepareCompute(list, c);
    list.dispatch(1);
    expectNoNewErrors();

    rhi::CommandList& other = dev().beginCommandList();
    other.bindPipeline(c.pipeline);
    other.bindGroup(0, c.set0);
    other.dispatch(1);
    expectExactError(
        "validation: dispatch: pipeline 'compute' declares set 1 but no bind group was bound to it");
    dev().submit(other);
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, BindGroupFromAnIncompatiblePipelineIsReported) {
    ComputeSetup c = makeComputeSetup();
    GraphicsSetup g = makeGraphicsSetup();
    rhi::CommandList& list = dev().beginCommandList();
    prepareCompute(list, c);
    list.bindGroup(1, g.set1);  // set 1 of the raster pipeline holds a read-only storage buffer
    list.dispatch(1);
    expectExactError(
        "validation: dispatch: bind group 'raster.set1' at set 1 was created for pipeline 'raster', whose "
        "set 1 "
        "layout differs from pipeline 'compute''s");
    list.bindGroup(1, c.set1);
    list.dispatch(1);
    dev().submit(list);
    expectNoNewErrors();
}

// --- missing barriers ---------------------------------------------------------------------------------

TEST_F(ValidationTest, SampledTextureInWriteStateIsAMissingBarrier) {
    ComputeSetup c = makeComputeSetup("gbuffer.depth");
    rhi::CommandList& list = dev().beginCommandList();
    prepareCompute(list, c);
    list.barrier(rhi::Barrier::tex(c.input, Access::ShaderSampled, Access::ShaderWrite));
    list.dispatch(1);
    expectExactError(
        "validation: dispatch: texture 'gbuffer.depth' (set 0, binding 2) is sampled but its state is "
        "ShaderWrite; "
        "add a barrier ShaderWrite -> ShaderSampled");
    list.barrier(rhi::Barrier::tex(c.input, Access::ShaderWrite, Access::ShaderSampled));
    list.dispatch(1);
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, TexturesStartInNoneAndNeedABarrier) {
    ComputeSetup c = makeComputeSetup();
    rhi::CommandList& list = dev().beginCommandList();
    list.bindPipeline(c.pipeline);
    list.bindGroup(0, c.set0);
    list.bindGroup(1, c.set1);
    list.barrier(rhi::Barrier::tex(c.input, Access::None, Access::ShaderSampled));
    list.dispatch(1);
    expectExactError(
        "validation: dispatch: texture 'outImage' (set 0, binding 1) is written as a storage image but its "
        "state is "
        "None; add a barrier None -> ShaderWrite");
    list.barrier(rhi::Barrier::tex(c.outImage, Access::None, Access::ShaderRead | Access::ShaderWrite));
    list.dispatch(1);
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, BarrierBeforeMustMatchTheTrackedState) {
    rhi::TextureHandle t = makeTexture("t");
    rhi::CommandList& list = dev().beginCommandList();
    list.barrier(rhi::Barrier::tex(t, Access::None, Access::ShaderWrite));
    list.barrier(rhi::Barrier::tex(t, Access::ShaderRead, Access::ShaderSampled));
    expectExactError(
        "validation: barrier: texture 't' barrier says before = ShaderRead but its tracked state is "
        "ShaderWrite");
    list.barrier(rhi::Barrier::tex(t, Access::ShaderSampled, Access::CopySrc));
    list.barrier(rhi::Barrier::tex(t, Access::None, Access::ColorTarget));  // None discards: always allowed
    dev().submit(list);
    expectNoNewErrors();
}

// Mip chain: read mip N as a storage image, write mip N + 1; barriers name one mip each.
const rhi::ShaderBinding kMipChainBindings[] = {
    binding("src", 0, 0, BindingType::StorageTexture, false),
    binding("dst", 0, 1, BindingType::StorageTexture, true),
};

TEST_F(ValidationTest, BarriersArePerSubresource) {
    // Criterion: a barrier on mip 1 only leaves mip 0 in its state (no false report when mip 0 is
    // read while mip 1 is written), and a missing barrier on one mip is reported for that mip.
    rhi::TextureHandle t =
        makeTexture("chain", rhi::Format::R32_UINT, TextureUsage::Storage | TextureUsage::CopyDst, 16, 3);
    rhi::ComputePipelineDesc pd;
    pd.shader = makeShader(rhi::ShaderStage::Compute, kMipChainBindings, 0, "downsample");
    pd.debugName = "downsample";
    rhi::PipelineHandle pipeline = dev().createComputePipeline(pd);
    auto group = [&](uint32_t srcMip) {
        rhi::BindGroupDesc g;
        g.pipeline = pipeline;
        g.entries = {rhi::BindGroupEntry::makeStorage(0, t, srcMip),
                     rhi::BindGroupEntry::makeStorage(1, t, srcMip + 1)};
        g.debugName = "chain" + std::to_string(srcMip);
        return dev().createBindGroup(g);
    };
    rhi::BindGroupHandle g0 = group(0), g1 = group(1);
    rhi::CommandList& list = dev().beginCommandList();
    list.barrier(rhi::Barrier::tex(t, Access::None, Access::ShaderRead, rhi::TextureRange{0, 1}));
    list.barrier(rhi::Barrier::tex(t, Access::None, Access::ShaderWrite, rhi::TextureRange{1, 1}));
    list.bindPipeline(pipeline);
    list.bindGroup(0, g0);
    list.dispatch(1);
    expectNoNewErrors();
    // Next step: mip 1 becomes the source; mip 2 was never transitioned (state None).
    list.barrier(rhi::Barrier::tex(t, Access::ShaderWrite, Access::ShaderRead, rhi::TextureRange{1, 1}));
    list.bindGroup(0, g1);
    list.dispatch(1);
    expectExactError(
        "validation: dispatch: texture 'chain' (mip 2, layer 0) (set 0, binding 1) is written as a storage "
        "image but its state is None; add a barrier None -> ShaderWrite");
    list.barrier(rhi::Barrier::tex(t, Access::None, Access::ShaderWrite, rhi::TextureRange{2, 1}));
    list.dispatch(1);
    expectNoNewErrors();
    // The tracked states stayed per mip: a barrier's `before` is checked against each mip.
    list.barrier(rhi::Barrier::tex(t, Access::ShaderRead, Access::CopySrc));
    expectExactError(
        "validation: barrier: texture 'chain' (mip 2, layer 0) barrier says before = ShaderRead but its "
        "tracked state is ShaderWrite");
    list.barrier(rhi::Barrier::tex(t, Access::ShaderRead, Access::CopySrc, rhi::TextureRange{0, 5}));
    expectExactError(
        "validation: barrier: texture 'chain' barrier names mips 0 +5, layers 0 +all but the texture has 3 "
        "mips and 1 layers");
    dev().submit(list);
    std::vector<uint8_t> out;
    EXPECT_TRUE(dev().readTexture(t, {0, 0}, Access::CopySrc, out));
    EXPECT_TRUE(dev().readTexture(t, {2, 0}, Access::CopySrc, out));
    expectNoNewErrors();
}

TEST_F(ValidationTest, RegionWritesAndCopiesAreChecked) {
    // Criterion: boxes outside the subresource, wrong sizes, overlapping self-copies, format
    // mismatches and copies from / to subresources not in CopySrc / CopyDst are each reported once.
    const TextureUsage usage = TextureUsage::CopySrc | TextureUsage::CopyDst | TextureUsage::Sampled;
    rhi::TextureHandle a = makeTexture("a", rhi::Format::R32_UINT, usage, 16, 2);
    rhi::TextureHandle b = makeTexture("b", rhi::Format::RGBA8_UNORM, usage, 16, 1);
    std::vector<uint32_t> words(64, 1);
    dev().writeTextureRegion(a, {0, 0, 12, 0, 0, 8, 4, 1}, words.data(), 8 * 4 * 4);
    expectExactError(
        "validation: writeTextureRegion: texture 'a': region at (12, 0, 0) of 8x4x1 leaves mip 0 (16x16x1)");
    dev().writeTextureRegion(a, {1, 0, 4, 4, 0, 4, 4, 1}, words.data(), 4);
    expectExactError(
        "validation: writeTextureRegion: texture 'a' region of 4x4x1 needs exactly 64 bytes of tightly "
        "packed "
        "texels, got 4");
    dev().writeTextureRegion(a, {1, 0, 4, 4, 0, 0, 0, 0}, words.data(), 64);  // zero extent: rest of mip 1
    expectNoNewErrors();

    rhi::BufferHandle staging = makeBuffer("staging", 256);
    rhi::CommandList& list = dev().beginCommandList();
    list.copyTexture(a, {0, 0, 0, 0, 0, 4, 4, 1}, a, {0, 0, 2, 2, 0, 0, 0, 0});
    expectExactError(
        "validation: copyTexture: 'a' -> 'a': source and destination boxes overlap in one subresource");
    list.copyTexture(a, {0, 0, 0, 0, 0, 4, 4, 1}, b, {});
    expectExactError("validation: copyTexture: 'a' -> 'b': formats differ (R32_UINT -> RGBA8_UNORM)");
    list.copyTexture(a, {0, 0, 0, 0, 0, 8, 8, 1}, a, {1, 0, 0, 0, 0, 0, 0, 0});
    EXPECT_EQ(m_errors.size(), m_expected + 2) << "src and dst both in ShaderSampled: two reports";
    m_expected = m_errors.size();
    list.barrier(rhi::Barrier::tex(a, Access::ShaderSampled, Access::CopySrc, rhi::TextureRange{0, 1}));
    list.barrier(rhi::Barrier::tex(a, Access::ShaderSampled, Access::CopyDst, rhi::TextureRange{1, 1}));
    list.copyTexture(a, {0, 0, 0, 0, 0, 8, 8, 1}, a, {1, 0, 0, 0, 0, 0, 0, 0});
    expectNoNewErrors();
    list.copyBufferToTexture(staging, 4, a, {1, 0, 0, 0, 0, 0, 0, 0});
    expectExactError(
        "validation: copyBufferToTexture: 'staging' -> 'a': 256 bytes at offset 4 exceed the "
        "buffer's 256 bytes");
    list.copyBufferToTexture(staging, 0, a, {1, 0, 0, 0, 0, 0, 0, 0});
    expectNoNewErrors();
    dev().submit(list);
}

TEST_F(ValidationTest, BindGroupMipRangesAreCheckedAndTracked) {
    // Criterion: a sampled view past the last mip is refused at creation; a view of mip 0 only is
    // not affected by mip 1 being in ShaderWrite, while a view of both mips is reported.
    rhi::TextureHandle t =
        makeTexture("pyramid", rhi::Format::R32_FLOAT, TextureUsage::Sampled | TextureUsage::Storage, 16, 2);
    rhi::PipelineHandle pipeline = makeComputePipeline();
    rhi::BufferHandle results = makeBuffer("results", 256);
    rhi::TextureHandle out = makeTexture("outImage");
    rhi::SamplerHandle sampler = makeSampler();
    auto group = [&](uint32_t baseMip, uint32_t mipCount) {
        rhi::BindGroupDesc g;
        g.pipeline = pipeline;
        g.entries = {rhi::BindGroupEntry::makeBuffer(0, results), rhi::BindGroupEntry::makeStorage(1, out),
                     rhi::BindGroupEntry::makeSampledMips(2, t, sampler, baseMip, mipCount)};
        g.debugName = "mips";
        return dev().createBindGroup(g);
    };
    EXPECT_FALSE(group(1, 2).isValid());
    expectExactError(
        "validation: createBindGroup: bind group 'mips' (pipeline 'compute', set 0) binding 2 ('inputTex') "
        "views texture 'pyramid': mips 1 +2, "
        "layers 0 "
        "+0 are outside the texture (2 mips, 1 layers)");
    rhi::BindGroupHandle mip0 = group(0, 1), both = group(0, 0);
    rhi::BindGroupDesc g1;
    g1.pipeline = pipeline;
    g1.set = 1;
    g1.entries = {rhi::BindGroupEntry::makeBuffer(0, makeBuffer("params", 64))};
    rhi::BindGroupHandle set1 = dev().createBindGroup(g1);
    rhi::CommandList& list = dev().beginCommandList();
    list.barrier(rhi::Barrier::tex(out, Access::None, Access::ShaderWrite));
    list.barrier(rhi::Barrier::tex(t, Access::None, Access::ShaderSampled, rhi::TextureRange{0, 1}));
    list.barrier(rhi::Barrier::tex(t, Access::None, Access::ShaderWrite, rhi::TextureRange{1, 1}));
    list.bindPipeline(pipeline);
    list.bindGroup(1, set1);
    list.bindGroup(0, mip0);
    list.dispatch(1);
    expectNoNewErrors();
    list.bindGroup(0, both);
    list.dispatch(1);
    expectExactError(
        "validation: dispatch: texture 'pyramid' (mip 1, layer 0) (set 0, binding 2) is sampled but its "
        "state is ShaderWrite; add a barrier ShaderWrite -> ShaderSampled");
    dev().submit(list);
}

TEST_F(ValidationTest, StorageUsageNeedsAStorageFormat) {
    // Criterion: Storage usage on a format formatSupport() reports without Storage is refused.
    EXPECT_FALSE(any(dev().formatSupport(rhi::Format::RGBA8_SRGB) & rhi::FormatSupport::Storage));
    EXPECT_FALSE(makeTexture("srgb", rhi::Format::RGBA8_SRGB, TextureUsage::Storage).isValid());
    expectExactError(
        "validation: createTexture: texture 'srgb' has Storage usage but the device has no storage images of "
        "format RGBA8_SRGB (formatSupport: sampled|filterable|colour|blend|vertex)");
    EXPECT_TRUE(makeTexture("srgb", rhi::Format::RGBA8_SRGB, TextureUsage::Sampled).isValid());
    EXPECT_TRUE(any(dev().formatSupport(rhi::Format::R32_UINT) & rhi::FormatSupport::StorageAtomic));
    expectNoNewErrors();
}

TEST_F(ValidationTest, ReadTextureNeedsTheTrackedState) {
    rhi::TextureHandle t = makeTexture("t");
    std::vector<uint8_t> texels(16 * 16 * 4, 7), out;
    EXPECT_FALSE(dev().readTexture(t, {}, Access::ShaderSampled, out));
    expectExactError(
        "validation: readTexture: texture 't' is passed as being in state ShaderSampled but its tracked "
        "state (last "
        "barrier / upload) is None");
    EXPECT_TRUE(dev().readTexture(t, {}, Access::None, out));
    dev().writeTexture(t, {}, texels.data(), texels.size());
    EXPECT_TRUE(dev().readTexture(t, {}, Access::ShaderSampled, out));
    EXPECT_EQ(out, texels);
    rhi::CommandList& list = dev().beginCommandList();
    list.barrier(rhi::Barrier::tex(t, Access::ShaderSampled, Access::ShaderWrite));
    dev().submit(list);
    EXPECT_TRUE(dev().readTexture(t, {}, Access::ShaderWrite, out));
    expectNoNewErrors();
}

TEST_F(ValidationTest, BuffersAreFreeUntilTheFirstGpuWrite) {
    ComputeSetup c = makeComputeSetup();
    GraphicsSetup g = makeGraphicsSetup();
    rhi::CommandList& list = dev().beginCommandList();
    // Host-initialised buffers: any use is fine, in any order.
    prepareCompute(list, c);
    list.dispatch(1);  // writes c.results (first GPU write)
    expectNoNewErrors();
    list.dispatch(1);  // write after write: allowed
    expectNoNewErrors();

    // Reading c.results as a read-only storage buffer (raster set 1) without a barrier.
    rhi::BindGroupDesc gd;
    gd.pipeline = g.pipeline;
    gd.set = 1;
    gd.entries = {rhi::BindGroupEntry::makeBuffer(0, c.results)};
    gd.debugName = "lightsFromCompute";
    rhi::BindGroupHandle fromCompute = dev().createBindGroup(gd);
    prepareGraphics(list, g);
    list.beginRenderPass(passFor(g));
    bindGraphics(list, g);
    list.bindGroup(1, fromCompute);
    list.draw(3);
    expectExactError(
        "validation: draw: buffer 'results' (set 1, binding 0) is read as a storage buffer but its state is "
        "ShaderWrite; add a barrier ShaderWrite -> ShaderRead");
    list.endRenderPass();
    list.barrier(rhi::Barrier::buf(c.results, Access::ShaderWrite, Access::ShaderRead));
    list.beginRenderPass(passFor(g));
    list.draw(3);
    list.endRenderPass();
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, CopiesNeedCopyStates) {
    rhi::BufferHandle a = makeBuffer("a", 64);
    rhi::BufferHandle b = makeBuffer("b", 64);
    rhi::CommandList& list = dev().beginCommandList();
    list.fillBuffer(a, 0, 64, 1);  // a: first GPU write -> CopyDst
    list.copyBuffer(a, 0, b, 0, 64);
    expectExactError(
        "validation: copyBuffer: buffer 'a' (src) is a copy source but its state is CopyDst; add a barrier "
        "CopyDst -> "
        "CopySrc");
    list.barrier(rhi::Barrier::buf(a, Access::CopyDst, Access::CopySrc));
    list.copyBuffer(a, 0, b, 0, 64);
    list.copyBuffer(a, 0, b, 0, 64);  // b stays CopyDst: write after write
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, AttachmentsNeedTargetStates) {
    GraphicsSetup g = makeGraphicsSetup();
    rhi::CommandList& list = dev().beginCommandList();
    list.barrier(rhi::Barrier::tex(g.color, Access::None, Access::ShaderSampled));
    list.barrier(rhi::Barrier::tex(g.depth, Access::None, Access::DepthTargetRead));
    list.beginRenderPass(passFor(g));
    // One report per attachment.
    m_expected += 1;
    expectExactError(
        "validation: beginRenderPass: texture 'depth' (depth attachment) is a depth target but its state is "
        "DepthTargetRead; add a barrier DepthTargetRead -> DepthTargetWrite");
    EXPECT_EQ(
        m_errors[m_errors.size() - 2],
        "validation: beginRenderPass: texture 'color' (colour attachment 0) is rendered to but its state is "
        "ShaderSampled; add a barrier ShaderSampled -> ColorTarget");
    list.endRenderPass();

    // A read-only depth attachment in DepthTargetRead is fine.
    list.barrier(rhi::Barrier::tex(g.color, Access::ShaderSampled, Access::ColorTarget));
    rhi::RenderPassDesc rp = passFor(g);
    rp.depthAttachment.readOnly = true;
    list.beginRenderPass(rp);
    list.endRenderPass();
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, VertexIndexAndIndirectBuffersNeedTheirStates) {
    rhi::BufferHandle vb = makeBuffer("vb", 256, BufferUsage::Vertex | BufferUsage::Storage);
    rhi::BufferHandle ib = makeBuffer("ib", 256, BufferUsage::Index | BufferUsage::CopyDst);
    rhi::BufferHandle args = makeBuffer("args", 64, BufferUsage::Indirect | BufferUsage::Storage);
    rhi::BufferHandle plain = makeBuffer("plain", 64, BufferUsage::Storage);
    ComputeSetup c = makeComputeSetup();
    rhi::CommandList& list = dev().beginCommandList();
    list.barrier(rhi::Barrier::buf(vb, Access::None, Access::ShaderWrite));
    list.bindVertexBuffer(0, vb);
    expectExactError(
        "validation: bindVertexBuffer: buffer 'vb' (slot 0) is read as a vertex buffer but its state is "
        "ShaderWrite; "
        "add a barrier ShaderWrite -> VertexRead");
    list.fillBuffer(ib, 0, 256, 0);
    list.bindIndexBuffer(ib, rhi::IndexType::Uint32);
    expectExactError(
        "validation: bindIndexBuffer: buffer 'ib' is read as an index buffer but its state is CopyDst; add a "
        "barrier "
        "CopyDst -> IndexRead");
    list.bindVertexBuffer(0, plain);
    expectExactError("validation: bindVertexBuffer: buffer 'plain' was created without Vertex usage");

    prepareCompute(list, c);
    list.barrier(rhi::Barrier::buf(args, Access::None, Access::ShaderWrite));
    list.dispatchIndirect(args, 0);
    expectExactError(
        "validation: dispatchIndirect: buffer 'args' (args) is read as indirect arguments but its state is "
        "ShaderWrite; add a barrier ShaderWrite -> IndirectRead");

    const rhi::Barrier fixes[] = {rhi::Barrier::buf(vb, Access::ShaderWrite, Access::VertexRead),
                                  rhi::Barrier::buf(ib, Access::CopyDst, Access::IndexRead),
                                  rhi::Barrier::buf(args, Access::ShaderWrite, Access::IndirectRead)};
    list.barrier(fixes);
    list.bindVertexBuffer(0, vb);
    list.bindIndexBuffer(ib, rhi::IndexType::Uint32);
    list.dispatchIndirect(args, 0);
    dev().submit(list);
    expectNoNewErrors();
}

TEST_F(ValidationTest, UniformStorageReadAndStorageWriteNeedTheirStates) {
    static const rhi::ShaderBinding kBindings[] = {
        binding("ubo", 0, 0, BindingType::UniformBuffer),
        binding("src", 0, 1, BindingType::StorageTexture, false),
        binding("dst", 0, 2, BindingType::StorageBuffer, true),
    };
    rhi::ComputePipelineDesc pd;
    pd.shader = makeShader(rhi::ShaderStage::Compute, kBindings, 0, "reader");
    pd.debugName = "reader";
    rhi::PipelineHandle p = dev().createComputePipeline(pd);
    rhi::BufferHandle ubo = makeBuffer("ubo", 64);
    rhi::BufferHandle dst = makeBuffer("dst", 64);
    rhi::TextureHandle src = makeTexture("src");
    rhi::BindGroupDesc gd;
    gd.pipeline = p;
    gd.entries = {rhi::BindGroupEntry::makeBuffer(0, ubo), rhi::BindGroupEntry::makeStorage(1, src),
                  rhi::BindGroupEntry::makeBuffer(2, dst)};
    rhi::BindGroupHandle g = dev().createBindGroup(gd);

    rhi::CommandList& list = dev().beginCommandList();
    list.fillBuffer(ubo, 0, 64, 0);  // GPU write: the UBO now needs a barrier
    const rhi::Barrier setup[] = {rhi::Barrier::tex(src, Access::None, Access::ShaderSampled),
                                  rhi::Barrier::buf(dst, Access::None, Access::ShaderRead)};
    list.barrier(setup);
    list.bindPipeline(p);
    list.bindGroup(0, g);
    list.dispatch(1);
    ASSERT_EQ(m_errors.size(), 3u);
    EXPECT_EQ(
        m_errors[0],
        "validation: dispatch: buffer 'ubo' (set 0, binding 0) is read as a uniform buffer but its state is "
        "CopyDst; add a barrier CopyDst -> UniformRead");
    EXPECT_EQ(
        m_errors[1],
        "validation: dispatch: texture 'src' (set 0, binding 1) is read as a storage image but its state is "
        "ShaderSampled; add a barrier ShaderSampled -> ShaderRead");
    EXPECT_EQ(m_errors[2],
              "validation: dispatch: buffer 'dst' (set 0, binding 2) is written as a storage buffer but its "
              "state is "
              "ShaderRead; add a barrier ShaderRead -> ShaderWrite");
    m_expected = 3;
    expectNoNewErrors();

    const rhi::Barrier fixes[] = {rhi::Barrier::buf(ubo, Access::CopyDst, Access::UniformRead),
                                  rhi::Barrier::tex(src, Access::ShaderSampled, Access::ShaderRead),
                                  rhi::Barrier::buf(dst, Access::ShaderRead, Access::ShaderWrite)};
    list.barrier(fixes);
    list.dispatch(1);
    dev().submit(list);
    expectNoNewErrors();
}

// --- a realistic, correct frame -----------------------------------------------------------------------

TEST_F(ValidationTest, CorrectFrameReportsNothing) {
    ComputeSetup c = makeComputeSetup();
    GraphicsSetup g = makeGraphicsSetup();
    rhi::BufferDesc vd;
    vd.size = 3 * 12;
    vd.usage = BufferUsage::Vertex | BufferUsage::Storage;
    vd.debugName = "triangle";
    const float verts[9] = {-1, -1, 0, 3, -1, 0, -1, 3, 0};
    rhi::BufferHandle vertices = dev().createBuffer(vd, verts);
    std::vector<uint8_t> albedo(16 * 16 * 4, 200);
    dev().writeTexture(g.albedo, {}, albedo.data(), albedo.size());  // -> ShaderSampled
    dev().writeTexture(c.input, {}, std::vector<uint8_t>(16 * 16 * 4).data(), 16 * 16 * 4);
    rhi::QueryPoolDesc qd;
    qd.count = 4;
    rhi::QueryPoolHandle queries = dev().createQueryPool(qd);

    // Graphics pipeline that samples the compute output and reads the compute-written buffer.
    rhi::BindGroupDesc fromCompute;
    fromCompute.pipeline = g.pipeline;
    fromCompute.entries = {rhi::BindGroupEntry::makeBuffer(0, g.camera),
                           rhi::BindGroupEntry::makeSampled(1, c.outImage, g.sampler)};
    fromCompute.debugName = "raster.fromCompute";
    rhi::BindGroupHandle set0 = dev().createBindGroup(fromCompute);
    fromCompute.set = 1;
    fromCompute.entries = {rhi::BindGroupEntry::makeBuffer(0, c.results)};
    rhi::BindGroupHandle set1 = dev().createBindGroup(fromCompute);

    rhi::CommandList& list = dev().beginCommandList("frame");
    list.resetQueries(queries, 0, 4);
    list.writeTimestamp(queries, 0);
    list.pushDebugGroup("compute");
    list.updateBuffer(c.params, 0, verts, 16);
    const rhi::Barrier pre[] = {rhi::Barrier::buf(c.params, Access::CopyDst, Access::UniformRead),
                                rhi::Barrier::tex(c.outImage, Access::None, Access::ShaderWrite)};
    list.barrier(pre);
    list.bindPipeline(c.pipeline);
    list.bindGroup(0, c.set0);
    list.bindGroup(1, c.set1);
    const uint32_t pc[4] = {1, 2, 3, 4};
    list.pushConstants(pc, sizeof(pc));
    list.dispatch(2, 2);
    list.popDebugGroup();
    list.writeTimestamp(queries, 1);

    const rhi::Barrier post[] = {rhi::Barrier::tex(c.outImage, Access::ShaderWrite, Access::ShaderSampled),
                                 rhi::Barrier::buf(c.results, Access::ShaderWrite, Access::ShaderRead),
                                 rhi::Barrier::tex(g.color, Access::None, Access::ColorTarget),
                                 rhi::Barrier::tex(g.depth, Access::None, Access::DepthTargetWrite)};
    list.barrier(post);
    list.pushDebugGroup("raster");
    list.beginRenderPass(passFor(g));
    list.setViewport({0, 0, 16, 16, 0, 1});
    list.setScissor({0, 0, 16, 16});
    list.bindPipeline(g.pipeline);
    list.bindGroup(0, set0);
    list.bindGroup(1, set1);
    list.pushConstants(pc, 8);
    list.bindVertexBuffer(0, vertices);
    list.draw(3);
    list.endRenderPass();
    list.popDebugGroup();
    list.barrier(rhi::Barrier::tex(g.color, Access::ColorTarget, Access::CopySrc));
    list.writeTimestamp(queries, 2);
    const uint64_t serial = dev().submit(list);
    dev().waitForSubmission(serial);

    std::vector<uint8_t> pixels;
    EXPECT_TRUE(dev().readTexture(g.color, {}, Access::CopySrc, pixels));
    uint64_t ns[3];
    EXPECT_TRUE(dev().readTimestamps(queries, 0, 3, ns));
    std::vector<uint8_t> results(256);
    EXPECT_TRUE(dev().readBuffer(c.results, 0, 256, results.data()));

    // Destroy everything; deferred destruction completes after the next submission.
    dev().destroy(set0);
    dev().destroy(set1);
    dev().destroy(vertices);
    dev().destroy(queries);
    dev().submit(dev().beginCommandList());
    expectNoNewErrors();

    // The wrapper is transparent to null-device inspection.
    const auto& cmds = rhi::null::recordedCommands(dev());
    size_t dispatches = 0, draws = 0;
    for (const auto& cmd : cmds) {
        dispatches += cmd.kind == rhi::null::RecordedCommand::Kind::Dispatch;
        draws += cmd.kind == rhi::null::RecordedCommand::Kind::Draw;
    }
    EXPECT_EQ(dispatches, 1u);
    EXPECT_EQ(draws, 1u);
    EXPECT_GT(rhi::null::liveObjectCount(dev()), 0u);
}

TEST_F(ValidationTest, DevicesWithoutValidationCountNothing) {
    rhi::DeviceDesc desc;
    desc.backend = rhi::Backend::Null;
    desc.log = [](rhi::LogSeverity, std::string_view) {};
    auto plain = rhi::createDevice(desc);
    ASSERT_NE(plain, nullptr);
    rhi::BufferDesc bd;
    plain->createBuffer(bd);  // size 0: the null device itself rejects it
    EXPECT_EQ(rhi::validationErrorCount(*plain), 0u);
}

}  // namespace
