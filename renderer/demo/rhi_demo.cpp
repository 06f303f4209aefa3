#include "renderer/demo/rhi_demo.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <shaders/demo_depth.h>
#include <shaders/demo_mesh.h>
#include <shaders/demo_shade.h>
#include <shaders/demo_trace.h>

#include "renderer/core/targets.h"

namespace penumbra::demo {
namespace {

rhi::BindGroupHandle makeBindGroup(rhi::Device& device, rhi::PipelineHandle pipeline, uint32_t set,
                                   std::vector<rhi::BindGroupEntry> entries, std::string name) {
    rhi::BindGroupDesc desc;
    desc.pipeline = pipeline;
    desc.set = set;
    desc.entries = std::move(entries);
    desc.debugName = std::move(name);
    return device.createBindGroup(desc);
}

// std430 / std140 mirrors of demo_common.glsl and demo_camera.glsl.
struct GpuPrimitive {
    glm::vec4 centerType;
    glm::vec4 params;
    glm::vec4 material;
};
struct GpuMaterial {
    glm::vec4 albedo;
};
struct GpuCamera {
    glm::mat4 viewProj;
    glm::mat4 invViewProj;
    glm::vec4 position;
    glm::vec4 forward;
    glm::vec4 lightDir;
    glm::vec4 projParams;
    glm::ivec4 counts;
};
static_assert(sizeof(GpuCamera) == 208);
struct MeshPush {
    glm::mat4 model;
    glm::vec4 material;
};
static_assert(sizeof(MeshPush) <= rhi::kMaxPushConstantSize);

constexpr glm::vec3 kVolumeHalfExtent{0.9f, 0.7f, 0.9f};

float smoothMin(float a, float b, float k) {
    float h = std::clamp(0.5f + 0.5f * (b - a) / k, 0.0f, 1.0f);
    return b + (a - b) * h - k * h * (1.0f - h);
}

struct Vertex {
    glm::vec3 position;
    glm::vec3 normal;
};

// Torus around the local y axis, `rings` x `sides` quads.
void makeTorus(float major, float minor, uint32_t rings, uint32_t sides, std::vector<Vertex>& vertices,
               std::vector<uint32_t>& indices) {
    const float twoPi = 6.28318530718f;
    for (uint32_t r = 0; r <= rings; ++r) {
        float u = twoPi * float(r) / float(rings);
        glm::vec3 ringCenter{major * std::cos(u), 0.0f, major * std::sin(u)};
        for (uint32_t s = 0; s <= sides; ++s) {
            float v = twoPi * float(s) / float(sides);
            glm::vec3 n{std::cos(v) * std::cos(u), std::sin(v), std::cos(v) * std::sin(u)};
            vertices.push_back({ringCenter + minor * n, n});
        }
    }
    for (uint32_t r = 0; r < rings; ++r) {
        for (uint32_t s = 0; s < sides; ++s) {
            uint32_t a = r * (sides + 1) + s, b = (r + 1) * (sides + 1) + s;
            indices.insert(indices.end(), {a, b, a + 1, a + 1, b, b + 1});
        }
    }
}

// Owns the device objects of one demo frame and destroys them (deferred) at scope exit.
struct Resources {
    rhi::Device& device;
    std::vector<rhi::BufferHandle> buffers;
    std::vector<rhi::TextureHandle> textures;
    std::vector<rhi::SamplerHandle> samplers;
    std::vector<rhi::ShaderHandle> shaders;
    std::vector<rhi::PipelineHandle> pipelines;

    explicit Resources(rhi::Device& d) : device(d) {}
    ~Resources() {
        for (auto h : pipelines) device.destroy(h);
        for (auto h : shaders) device.destroy(h);
        for (auto h : samplers) device.destroy(h);
        for (auto h : textures) device.destroy(h);
        for (auto h : buffers) device.destroy(h);
    }
    rhi::BufferHandle buffer(const rhi::BufferDesc& d, const void* data) {
        auto h = device.createBuffer(d, data);
        if (h) buffers.push_back(h);
        return h;
    }
    rhi::ShaderHandle shader(const rhi::ShaderDesc& d) {
        auto h = device.createShader(d);
        if (h) shaders.push_back(h);
        return h;
    }
    rhi::PipelineHandle keep(rhi::PipelineHandle h) {
        if (h) pipelines.push_back(h);
        return h;
    }
};

}  // namespace

float demoVolumeDistance(float x, float y, float z) {
    glm::vec3 p{x, y, z};
    float a = glm::length(p - glm::vec3(-0.35f, -0.15f, 0.0f)) - 0.42f;
    float b = glm::length(p - glm::vec3(0.35f, -0.1f, 0.1f)) - 0.38f;
    float c = glm::length(p - glm::vec3(0.0f, 0.3f, -0.1f)) - 0.32f;
    return smoothMin(smoothMin(a, b, 0.25f), c, 0.25f);
}

DemoResult renderDemoFrame(rhi::Device& device, const DemoSettings& settings) {
    DemoResult result;
    auto fail = [&](std::string why) {
        result.ok = false;
        result.error = std::move(why);
        return result;
    };
    if (settings.width == 0 || settings.height == 0 || settings.width > 8192 || settings.height > 8192)
        return fail("image size must be between 1x1 and 8192x8192");
    if (settings.volumeResolution < 2 || settings.volumeResolution > 256)
        return fail("volume resolution must be between 2 and 256");

    const uint32_t w = settings.width, h = settings.height;
    Resources res(device);

    // --- scene data ---------------------------------------------------------------------------
    const std::vector<GpuMaterial> materials = {
        {{0.42f, 0.42f, 0.40f, 1}},  // 0 ground
        {{0.75f, 0.12f, 0.10f, 1}},  // 1 sphere
        {{0.10f, 0.25f, 0.75f, 1}},  // 2 box
        {{0.85f, 0.60f, 0.15f, 1}},  // 3 sampled volume
        {{0.15f, 0.65f, 0.25f, 1}},  // 4 mesh
    };
    const std::vector<GpuPrimitive> prims = {
        {{0, 0, 0, 2}, {0, 1, 0, 0}, {0, 0, 0, 0}},
        {{-1.75f, 0.8f, 0.1f, 0}, {0.8f, 0, 0, 0}, {1, 0, 0, 0}},
        {{1.55f, 0.5f, 0.3f, 1}, {0.5f, 0.5f, 0.5f, 0}, {2, 0, 0, 0}},
        {{-0.25f, 0.7f, -1.2f, 3}, {kVolumeHalfExtent, 0}, {3, 0, 0, 0}},
    };

    const glm::vec3 eye{0.6f, 2.9f, 6.4f}, target{0.0f, 0.45f, -0.2f};
    const float nearPlane = 0.1f, farPlane = 60.0f;
    glm::mat4 view = glm::lookAtRH(eye, target, glm::vec3(0, 1, 0));
    glm::mat4 proj = glm::perspectiveRH_ZO(glm::radians(45.0f), float(w) / float(h), nearPlane, farPlane);
    proj[1][1] *= -1.0f;  // Vulkan clip space: NDC y = -1 is image row 0 (top)
    GpuCamera camera{};
    camera.viewProj = proj * view;
    camera.invViewProj = glm::inverse(camera.viewProj);
    camera.position = glm::vec4(eye, 1);
    camera.forward = glm::vec4(glm::normalize(target - eye), 0);
    camera.lightDir = glm::vec4(glm::normalize(glm::vec3(-0.55f, 0.75f, 0.4f)), 1.6f);
    camera.projParams = {proj[2][2], proj[3][2], nearPlane, farPlane};
    camera.counts = {int(prims.size()), int(w), int(h), 0};

    std::vector<Vertex> vertices;
    std::vector<uint32_t> indices;
    makeTorus(0.55f, 0.2f, 48, 24, vertices, indices);
    MeshPush meshPush;
    meshPush.model = glm::rotate(glm::translate(glm::mat4(1), glm::vec3(0.75f, 0.55f, 1.55f)),
                                 glm::radians(58.0f), glm::vec3(1, 0, 0.3f));
    meshPush.material = {4, 0, 0, 0};

    using BU = rhi::BufferUsage;
    auto cameraBuf = res.buffer(
        {sizeof(GpuCamera), BU::Uniform | BU::CopyDst, rhi::MemoryType::GpuOnly, "demo.camera"}, &camera);
    auto primBuf = res.buffer({prims.size() * sizeof(GpuPrimitive), BU::Storage | BU::CopyDst,
                               rhi::MemoryType::GpuOnly, "demo.primitives"},
                              prims.data());
    auto matBuf = res.buffer({materials.size() * sizeof(GpuMaterial), BU::Storage | BU::CopyDst,
                              rhi::MemoryType::GpuOnly, "demo.materials"},
                             materials.data());
    auto vertexBuf = res.buffer({vertices.size() * sizeof(Vertex), BU::Vertex | BU::CopyDst,
                                 rhi::MemoryType::GpuOnly, "demo.torus.vertices"},
                                vertices.data());
    auto indexBuf = res.buffer({indices.size() * sizeof(uint32_t), BU::Index | BU::CopyDst,
                                rhi::MemoryType::GpuOnly, "demo.torus.indices"},
                               indices.data());
    if (!cameraBuf || !primBuf || !matBuf || !vertexBuf || !indexBuf) return fail("buffer creation failed");

    // Procedural distance volume, sampled trilinearly by the trace and shade passes.
    const uint32_t n = settings.volumeResolution;
    std::vector<float> volume(size_t(n) * n * n);
    for (uint32_t z = 0; z < n; ++z)
        for (uint32_t y = 0; y < n; ++y)
            for (uint32_t x = 0; x < n; ++x) {
                glm::vec3 uvw = (glm::vec3(x, y, z) + 0.5f) / float(n);
                glm::vec3 p = (uvw - 0.5f) * 2.0f * kVolumeHalfExtent;
                volume[(size_t(z) * n + y) * n + x] = demoVolumeDistance(p.x, p.y, p.z);
            }
    rhi::TextureDesc volDesc;
    volDesc.dimension = rhi::TextureDimension::Tex3D;
    volDesc.format = rhi::Format::R32_FLOAT;
    volDesc.width = volDesc.height = volDesc.depthOrLayers = n;
    volDesc.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::CopyDst;
    volDesc.debugName = "demo.volume";
    auto volumeTex = device.createTexture(volDesc);
    if (!volumeTex) return fail("3D texture creation failed");
    res.textures.push_back(volumeTex);
    device.writeTexture(volumeTex, {}, volume.data(), volume.size() * sizeof(float));

    rhi::SamplerDesc linearDesc;
    linearDesc.debugName = "demo.linear_clamp";
    auto linearSampler = device.createSampler(linearDesc);
    rhi::SamplerDesc nearestDesc;
    nearestDesc.minFilter = nearestDesc.magFilter = rhi::Filter::Nearest;
    nearestDesc.debugName = "demo.nearest_clamp";
    auto nearestSampler = device.createSampler(nearestDesc);
    if (!linearSampler || !nearestSampler) return fail("sampler creation failed");
    res.samplers = {linearSampler, nearestSampler};

    rhi::TextureDesc finalDesc;
    finalDesc.format = rhi::Format::RGBA8_UNORM;
    finalDesc.width = w;
    finalDesc.height = h;
    finalDesc.usage = rhi::TextureUsage::ColorTarget | rhi::TextureUsage::CopySrc;
    finalDesc.debugName = "demo.final";
    auto finalTex = device.createTexture(finalDesc);
    if (!finalTex) return fail("output texture creation failed");
    res.textures.push_back(finalTex);

    // --- pipelines -----------------------------------------------------------------------------
    auto traceCs = res.shader(shaders::demo_trace::compute());
    auto depthVs = res.shader(shaders::demo_depth::vertex());
    auto depthFs = res.shader(shaders::demo_depth::fragment());
    auto meshVs = res.shader(shaders::demo_mesh::vertex());
    auto meshFs = res.shader(shaders::demo_mesh::fragment());
    auto shadeVs = res.shader(shaders::demo_shade::vertex());
    auto shadeFs = res.shader(shaders::demo_shade::fragment());
    if (!traceCs || !depthVs || !depthFs || !meshVs || !meshFs || !shadeVs || !shadeFs)
        return fail("shader creation failed");

    auto tracePipe = res.keep(device.createComputePipeline({traceCs, "demo.trace"}));

    rhi::GraphicsPipelineDesc depthDesc;
    depthDesc.vertexShader = depthVs;
    depthDesc.fragmentShader = depthFs;
    depthDesc.depthTest = true;
    depthDesc.depthWrite = true;
    depthDesc.depthCompare = rhi::CompareOp::Always;
    depthDesc.depthFormat = rhi::Format::D32_FLOAT;
    depthDesc.debugName = "demo.depth";
    auto depthPipe = res.keep(device.createGraphicsPipeline(depthDesc));

    rhi::GraphicsPipelineDesc meshDesc;
    meshDesc.vertexShader = meshVs;
    meshDesc.fragmentShader = meshFs;
    meshDesc.vertexBuffers = {{sizeof(Vertex), false}};
    meshDesc.vertexAttributes = {{0, 0, rhi::Format::RGB32_FLOAT, offsetof(Vertex, position)},
                                 {1, 0, rhi::Format::RGB32_FLOAT, offsetof(Vertex, normal)}};
    meshDesc.cullMode = rhi::CullMode::None;
    meshDesc.depthTest = true;
    meshDesc.depthWrite = true;
    meshDesc.depthCompare = rhi::CompareOp::Less;
    meshDesc.colorFormats = {rhi::Format::RGBA16_FLOAT, rhi::Format::R32_FLOAT};
    meshDesc.depthFormat = rhi::Format::D32_FLOAT;
    meshDesc.debugName = "demo.mesh";
    auto meshPipe = res.keep(device.createGraphicsPipeline(meshDesc));

    rhi::GraphicsPipelineDesc shadeDesc;
    shadeDesc.vertexShader = shadeVs;
    shadeDesc.fragmentShader = shadeFs;
    shadeDesc.colorFormats = {rhi::Format::RGBA8_UNORM};
    shadeDesc.debugName = "demo.shade";
    auto shadePipe = res.keep(device.createGraphicsPipeline(shadeDesc));
    if (!tracePipe || !depthPipe || !meshPipe || !shadePipe) return fail("pipeline creation failed");

    // --- frame graph ---------------------------------------------------------------------------
    std::string graphError;
    fg::FrameGraph graph(device, [&](rhi::LogSeverity s, std::string_view msg) {
        if (s == rhi::LogSeverity::Error) graphError += std::string(msg) + "\n";
    });
    graph.reset();
    auto volumeRef = graph.importTexture("volume", volumeTex, rhi::Access::ShaderSampled);
    auto finalRef = graph.importTexture("final", finalTex, rhi::Access::None, rhi::Access::CopySrc);
    graph.markOutput(finalRef);

    auto rtDesc = [&](rhi::Format f, const char* name) {
        rhi::TextureDesc d;
        d.format = f;
        d.width = w;
        d.height = h;
        d.usage = rhi::TextureUsage::None;  // the graph derives usage from the declared accesses
        d.debugName = name;
        return d;
    };

    struct Gbuffer {
        fg::TextureRef normal, viewDepth, depth;
    };
    Gbuffer gb;

    // 1. trace: compute sphere tracing into the G-buffer.
    graph.addPass<Gbuffer>(
        "trace", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Gbuffer& d) {
            d.normal = b.createTexture("gbuffer.normal", rtDesc(rhi::Format::RGBA16_FLOAT, "gbuffer.normal"));
            d.viewDepth =
                b.createTexture("gbuffer.view_depth", rtDesc(rhi::Format::R32_FLOAT, "gbuffer.view_depth"));
            b.write(d.normal, rhi::Access::ShaderWrite);
            b.write(d.viewDepth, rhi::Access::ShaderWrite);
            b.read(volumeRef, rhi::Access::ShaderSampled);
            gb.normal = d.normal;
            gb.viewDepth = d.viewDepth;
        },
        [&](const Gbuffer& d, fg::PassContext& ctx) {
            auto scene = makeBindGroup(
                ctx.device, tracePipe, 0,
                {rhi::BindGroupEntry::makeBuffer(0, cameraBuf), rhi::BindGroupEntry::makeBuffer(1, primBuf),
                 rhi::BindGroupEntry::makeBuffer(2, matBuf),
                 rhi::BindGroupEntry::makeSampled(3, ctx.texture(volumeRef), linearSampler)},
                "demo.trace.scene");
            auto out = makeBindGroup(ctx.device, tracePipe, 1,
                                             {rhi::BindGroupEntry::makeStorage(0, ctx.texture(d.normal)),
                                              rhi::BindGroupEntry::makeStorage(1, ctx.texture(d.viewDepth))},
                                             "demo.trace.gbuffer");
            ctx.cmd.bindPipeline(tracePipe);
            ctx.cmd.bindGroup(0, scene);
            ctx.cmd.bindGroup(1, out);
            ctx.cmd.dispatch((w + 7) / 8, (h + 7) / 8);
            ctx.device.destroy(scene);
            ctx.device.destroy(out);
        });

    // 2. depth: traced view depth -> hardware depth, so the mesh is depth-tested against it.
    graph.addPass<Gbuffer>(
        "depth", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Gbuffer& d) {
            d.viewDepth = gb.viewDepth;
            d.depth = b.createTexture("gbuffer.depth", rtDesc(rhi::Format::D32_FLOAT, "gbuffer.depth"));
            b.read(d.viewDepth, rhi::Access::ShaderSampled);
            b.write(d.depth, rhi::Access::DepthTargetWrite);
            gb.depth = d.depth;
        },
        [&](const Gbuffer& d, fg::PassContext& ctx) {
            auto camGroup =
                makeBindGroup(ctx.device, depthPipe, 0,
                                      {rhi::BindGroupEntry::makeBuffer(0, cameraBuf)}, "demo.depth.camera");
            auto src = makeBindGroup(
                ctx.device, depthPipe, 1,
                {rhi::BindGroupEntry::makeSampled(0, ctx.texture(d.viewDepth), nearestSampler)},
                "demo.depth.source");
            rhi::RenderPassDesc rp;
            rp.depthAttachment.texture = ctx.texture(d.depth);
            rp.depthAttachment.load = rhi::LoadOp::DontCare;
            rp.debugName = "demo.depth";
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.setViewport({0, 0, float(w), float(h), 0, 1});
            ctx.cmd.setScissor({0, 0, w, h});
            ctx.cmd.bindPipeline(depthPipe);
            ctx.cmd.bindGroup(0, camGroup);
            ctx.cmd.bindGroup(1, src);
            ctx.cmd.draw(3);
            ctx.cmd.endRenderPass();
            ctx.device.destroy(camGroup);
            ctx.device.destroy(src);
        });

    // 3. mesh: rasterise the torus into the same G-buffer with depth test.
    graph.addPass<Gbuffer>(
        "mesh", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Gbuffer& d) {
            // A write keeps the previous version (LoadOp::Load): the traced surfaces stay.
            d = gb;
            b.write(d.normal, rhi::Access::ColorTarget);
            b.write(d.viewDepth, rhi::Access::ColorTarget);
            b.write(d.depth, rhi::Access::DepthTargetWrite);
        },
        [&](const Gbuffer& d, fg::PassContext& ctx) {
            auto camGroup = makeBindGroup(
                ctx.device, meshPipe, 0, {rhi::BindGroupEntry::makeBuffer(0, cameraBuf)}, "demo.mesh.camera");
            rhi::RenderPassDesc rp;
            rp.colorAttachments = {{ctx.texture(d.normal), 0, 0, rhi::LoadOp::Load},
                                   {ctx.texture(d.viewDepth), 0, 0, rhi::LoadOp::Load}};
            rp.depthAttachment.texture = ctx.texture(d.depth);
            rp.depthAttachment.load = rhi::LoadOp::Load;
            rp.depthAttachment.store = rhi::StoreOp::DontCare;
            rp.debugName = "demo.mesh";
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.setViewport({0, 0, float(w), float(h), 0, 1});
            ctx.cmd.setScissor({0, 0, w, h});
            ctx.cmd.bindPipeline(meshPipe);
            ctx.cmd.bindGroup(0, camGroup);
            ctx.cmd.pushConstants(&meshPush, sizeof(meshPush));
            ctx.cmd.bindVertexBuffer(0, vertexBuf);
            ctx.cmd.bindIndexBuffer(indexBuf, rhi::IndexType::Uint32);
            ctx.cmd.drawIndexed(uint32_t(indices.size()));
            ctx.cmd.endRenderPass();
            ctx.device.destroy(camGroup);
        });

    // 4. shade: deferred lighting into the output image.
    graph.addPass<Gbuffer>(
        "shade", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Gbuffer& d) {
            d = gb;
            b.read(d.normal, rhi::Access::ShaderSampled);
            b.read(d.viewDepth, rhi::Access::ShaderSampled);
            b.read(volumeRef, rhi::Access::ShaderSampled);
            b.write(finalRef, rhi::Access::ColorTarget);
        },
        [&](const Gbuffer& d, fg::PassContext& ctx) {
            auto scene = makeBindGroup(
                ctx.device, shadePipe, 0,
                {rhi::BindGroupEntry::makeBuffer(0, cameraBuf), rhi::BindGroupEntry::makeBuffer(1, primBuf),
                 rhi::BindGroupEntry::makeBuffer(2, matBuf),
                 rhi::BindGroupEntry::makeSampled(3, ctx.texture(volumeRef), linearSampler)},
                "demo.shade.scene");
            auto gbuf = makeBindGroup(
                ctx.device, shadePipe, 1,
                {rhi::BindGroupEntry::makeSampled(0, ctx.texture(d.normal), nearestSampler),
                 rhi::BindGroupEntry::makeSampled(1, ctx.texture(d.viewDepth), nearestSampler)},
                "demo.shade.gbuffer");
            rhi::RenderPassDesc rp;
            rp.colorAttachments = {{ctx.texture(finalRef), 0, 0, rhi::LoadOp::DontCare}};
            rp.debugName = "demo.shade";
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.setViewport({0, 0, float(w), float(h), 0, 1});
            ctx.cmd.setScissor({0, 0, w, h});
            ctx.cmd.bindPipeline(shadePipe);
            ctx.cmd.bindGroup(0, scene);
            ctx.cmd.bindGroup(1, gbuf);
            ctx.cmd.draw(3);
            ctx.cmd.endRenderPass();
            ctx.device.destroy(scene);
            ctx.device.destroy(gbuf);
        });

    if (!graph.compile()) return fail("frame graph compilation failed: " + graphError);
    result.graphviz = graph.toGraphviz();
    rhi::CommandList& cmd = device.beginCommandList("demo.frame");
    graph.execute(cmd);
    device.submit(cmd);
    result.timings = graph.collectTimings();

    std::vector<uint8_t> pixels;
    if (!device.readTexture(finalTex, {}, rhi::Access::CopySrc, pixels) || pixels.size() != size_t(w) * h * 4)
        return fail("readback of the output image failed");
    result.image.width = w;
    result.image.height = h;
    result.image.pixels = std::move(pixels);
    if (!graphError.empty()) return fail("frame graph reported errors: " + graphError);
    result.ok = true;
    return result;
}

}  // namespace penumbra::demo
