// The scene renderer: gathers the frame from the World (camera, visible MeshRenderers, lights,
// the materials they use), makes sure the GPU copies of meshes and textures exist, keeps the
// persistent G-buffer targets and the velocity history, and builds the frame graph from the passes
// in renderer/passes/ (scene_upload -> gbuffer_mesh -> lighting).
//
// Frame rules (documented here, tested in tests/renderer/scene_renderer_test.cpp):
// - Draw order and material indices: visible MeshRenderer entities that have a Transform are drawn
//   in ascending entity index; materials get indices 0, 1, ... in order of first use in that order
//   (material id 0 = the default ecs::Material). At most 65536 materials per frame (the G-buffer's
//   16-bit index, the scene format's limit).
//   A MeshRenderer without a Transform is not drawn.
// - Camera: projection perspectiveRH_ZO(fovY, width / height, near, far) with proj[1][1] negated
//   (Vulkan clip space, NDC y = -1 is image row 0, depth 0..1); view = inverse of the camera's world
//   matrix with its scale removed (rotation and translation only), so linear depth is in scene units.
// - Velocity history: the previous frame's view-projection (reset to the current one when the camera
//   entity changes) and every drawn entity's previous world matrix (the current one on an entity's
//   first frame); entities not drawn in a frame are forgotten.
// - Lights: entities with Light + Transform, in ascending entity index.
// - A referenced asset that is missing (mesh, material, base-colour texture) fails the frame.
#include "renderer/scene_renderer.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <fmt/format.h>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "renderer/passes/deferred_lighting.h"
#include "renderer/passes/gbuffer_mesh.h"
#include "renderer/passes/gpu_scene.h"
#include "renderer/passes/lighting_reference.h"
#include "renderer/passes/pass_common.h"
#include "renderer/passes/scene_upload.h"

namespace penumbra::render {
namespace {

constexpr uint32_t kMaxMaterialsPerFrame = 65536;

enum TargetId : uint32_t { kDepth, kNormal, kMaterial, kVelocity, kAlbedo, kOutput, kTargetCount };

struct TargetInfo {
    const char* name;
    rhi::Format format;
};
constexpr TargetInfo kTargets[kTargetCount] = {
    {"gbuffer.depth", rhi::Format::R32_FLOAT},      {"gbuffer.normal", rhi::Format::RG16_FLOAT},
    {"gbuffer.material", rhi::Format::RGBA8_UNORM}, {"gbuffer.velocity", rhi::Format::RG16_FLOAT},
    {"gbuffer.albedo", rhi::Format::RGBA8_SRGB},    {"output", rhi::Format::RGBA8_UNORM},
};

// A render target owned by the renderer, imported into every frame that uses it.
struct Target {
    rhi::TextureHandle handle;
    rhi::Access state = rhi::Access::None;  // where the last frame left it
    uint64_t bytes = 0;
};

struct DrawSource {
    ecs::Entity entity;
    const ecs::MeshRenderer* renderer = nullptr;
    glm::mat4 model{1.0f};
};

bool finite(const glm::mat4& m) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r])) return false;
    return true;
}

std::string entityName(ecs::Entity e) { return fmt::format("entity {}v{}", e.index, e.generation); }

}  // namespace

struct SceneRenderer::Impl {
    rhi::Device& device;
    std::string graphErrors;
    fg::FrameGraph graph;
    GpuAssetCache cache;
    GBufferMeshPass gbufferPass;
    DeferredLightingPass lightingPass;

    uint32_t width = 0, height = 0;
    Target targets[kTargetCount];

    // velocity history
    bool haveHistory = false;
    ecs::Entity historyCamera;
    glm::mat4 prevViewProj{1.0f};
    std::unordered_map<ecs::Entity, glm::mat4> prevModels;

    // the last frame
    SceneFrameData frameData;  // read by scene_upload's execute
    FrameStats stats;
    std::string graphviz;
    bool haveFrame = false;
    bool lastOwnOutput = false;
    bool lastGbuffer = false;
    bool lastAlbedo = false;

    explicit Impl(rhi::Device& d)
        : device(d),
          graph(d,
                [this](rhi::LogSeverity s, std::string_view msg) {
                    if (s == rhi::LogSeverity::Error) graphErrors.append(msg).append("\n");
                }),
          cache(d),
          gbufferPass(d),
          lightingPass(d) {}

    ~Impl() {
        for (Target& t : targets) release(t);
    }

    void release(Target& t) {
        if (t.handle) device.destroy(t.handle);
        t = {};
    }

    bool ensureTarget(TargetId id, std::string& error) {
        Target& t = targets[id];
        if (t.handle) return true;
        using TU = rhi::TextureUsage;
        rhi::TextureDesc d = renderTargetDesc(kTargets[id].format, width, height, kTargets[id].name,
                                              TU::ColorTarget | TU::Sampled | TU::CopySrc);
        t.handle = device.createTexture(d);
        if (!t.handle) {
            error =
                fmt::format("creating the {}x{} render target '{}' failed", width, height, kTargets[id].name);
            return false;
        }
        t.state = rhi::Access::None;
        t.bytes = textureBytes(d);
        return true;
    }

    uint64_t targetBytes() const {
        uint64_t total = 0;
        for (const Target& t : targets) total += t.bytes;
        return total;
    }
};

SceneRenderer::SceneRenderer(rhi::Device& device) : m_impl(std::make_unique<Impl>(device)) {}

SceneRenderer::~SceneRenderer() = default;

bool SceneRenderer::render(const ecs::World& world, const assets::AssetManager& assets, const FrameDesc& desc,
                           std::string& error) {
    Impl& s = *m_impl;
    error.clear();
    auto fail = [&](std::string message) {
        error = "scene renderer: ";
        error.append(message);
        return false;
    };

    // ---- frame description --------------------------------------------------------------------
    const uint32_t maxSize = std::max<uint32_t>(s.device.info().limits.maxTextureSize2D, 1);
    if (desc.width == 0 || desc.height == 0 || desc.width > maxSize || desc.height > maxSize)
        return fail(
            fmt::format("frame size {}x{} is invalid (1..{} per side)", desc.width, desc.height, maxSize));
    if (desc.camera.isNull()) return fail("no camera: FrameDesc::camera is the null entity");
    const ecs::Camera* camera = world.get<ecs::Camera>(desc.camera);
    const ecs::Transform* cameraTransform = world.get<ecs::Transform>(desc.camera);
    if (!world.alive(desc.camera) || !camera || !cameraTransform)
        return fail(
            fmt::format("no camera: {} (FrameDesc::camera) {}", entityName(desc.camera),
                        !world.alive(desc.camera) ? "is not alive" : "does not have Camera and Transform"));
    if (!std::isfinite(camera->fovY) || camera->fovY <= 0.0f || camera->fovY >= 3.14159f ||
        !std::isfinite(camera->nearPlane) || !std::isfinite(camera->farPlane) || camera->nearPlane <= 0.0f ||
        camera->farPlane <= camera->nearPlane)
        return fail(fmt::format("camera {}: fovY {} must be in (0, pi) and 0 < near {} < far {}",
                                entityName(desc.camera), camera->fovY, camera->nearPlane, camera->farPlane));
    const bool external = desc.target.isValid();
    // An RGBA8_SRGB target (e.g. the GL window backbuffer) encodes in hardware; RGBA8_UNORM targets
    // get the exact sRGB OETF in the shader.
    bool hardwareSrgb = false;
    if (external) {
        const rhi::TextureDesc* td = s.device.describe(desc.target);
        if (!td) return fail("FrameDesc::target is not a live texture");
        if ((td->format != rhi::Format::RGBA8_UNORM && td->format != rhi::Format::RGBA8_SRGB) ||
            td->width != desc.width || td->height != desc.height ||
            !any(td->usage & rhi::TextureUsage::ColorTarget))
            return fail(
                fmt::format("FrameDesc::target '{}' must be an RGBA8_UNORM or RGBA8_SRGB colour target of "
                            "{}x{} (it is {} "
                            "{}x{})",
                            td->debugName, desc.width, desc.height, rhi::formatInfo(td->format).name,
                            td->width, td->height));
        hardwareSrgb = td->format == rhi::Format::RGBA8_SRGB;
    }

    // Camera basis without scale: forward = -Z, right = X, up = Y (Gram-Schmidt).
    const glm::mat4& cw = cameraTransform->worldMatrix;
    if (!finite(cw))
        return fail(fmt::format("camera {}: world matrix is not finite", entityName(desc.camera)));
    glm::vec3 zAxis = glm::vec3(cw[2]);
    glm::vec3 xAxis = glm::vec3(cw[0]);
    if (glm::length(zAxis) < 1e-12f || glm::length(xAxis) < 1e-12f)
        return fail(fmt::format("camera {}: world matrix is degenerate", entityName(desc.camera)));
    zAxis = glm::normalize(zAxis);
    xAxis = xAxis - zAxis * glm::dot(xAxis, zAxis);
    if (glm::length(xAxis) < 1e-12f)
        return fail(fmt::format("camera {}: world matrix is degenerate", entityName(desc.camera)));
    xAxis = glm::normalize(xAxis);
    const glm::vec3 yAxis = glm::cross(zAxis, xAxis);
    const glm::vec3 eye = glm::vec3(cw[3]);
    glm::mat4 cameraRigid(glm::vec4(xAxis, 0), glm::vec4(yAxis, 0), glm::vec4(zAxis, 0), glm::vec4(eye, 1));
    const glm::mat4 view = glm::affineInverse(cameraRigid);
    glm::mat4 proj = glm::perspectiveRH_ZO(camera->fovY, float(desc.width) / float(desc.height),
                                           camera->nearPlane, camera->farPlane);
    proj[1][1] *= -1.0f;  // Vulkan clip space: NDC y = -1 is image row 0
    const glm::mat4 viewProj = proj * view;

    // ---- gather draws, materials, lights ---------------------------------------------------------
    std::vector<DrawSource> sources;
    for (auto [e, mr, t] : world.view<ecs::MeshRenderer, ecs::Transform>()) {
        if (mr.visible) sources.push_back({e, &mr, t.worldMatrix});
    }
    std::sort(sources.begin(), sources.end(),
              [](const DrawSource& a, const DrawSource& b) { return a.entity.index < b.entity.index; });

    static const ecs::Material kDefaultMaterial{};
    std::unordered_map<assets::AssetId, uint32_t> materialIndex;
    std::vector<const ecs::Material*> materials;
    std::vector<uint32_t> drawMaterial(sources.size());
    std::vector<const assets::MeshData*> drawMesh(sources.size());
    bool albedo = false;
    for (size_t i = 0; i < sources.size(); ++i) {
        const DrawSource& src = sources[i];
        const ecs::MeshRenderer& mr = *src.renderer;
        if (mr.mesh == 0)
            return fail(fmt::format("{} (MeshRenderer): no mesh asset (id 0)", entityName(src.entity)));
        drawMesh[i] = assets.mesh(mr.mesh);
        if (!drawMesh[i])
            return fail(fmt::format("{} (MeshRenderer): mesh asset {:016x} is not loaded",
                                    entityName(src.entity), mr.mesh));
        if (!finite(src.model))
            return fail(fmt::format("{} (MeshRenderer): world matrix is not finite", entityName(src.entity)));
        auto it = materialIndex.find(mr.material);
        if (it == materialIndex.end()) {
            const ecs::Material* m = mr.material == 0 ? &kDefaultMaterial : assets.material(mr.material);
            if (!m)
                return fail(fmt::format("{} (MeshRenderer): material asset {:016x} is not loaded",
                                        entityName(src.entity), mr.material));
            if (m->baseColorTexture != 0) {
                if (!assets.texture(m->baseColorTexture))
                    return fail(
                        fmt::format("{} (MeshRenderer): material {:016x}: base-colour texture {:016x} is not "
                                    "loaded",
                                    entityName(src.entity), mr.material, m->baseColorTexture));
                albedo = true;
            }
            it = materialIndex.emplace(mr.material, uint32_t(materials.size())).first;
            materials.push_back(m);
        }
        drawMaterial[i] = it->second;
    }
    if (materials.size() > kMaxMaterialsPerFrame)
        return fail(
            fmt::format("more than {} materials in one frame ({} used by the visible MeshRenderers; "
                        "the G-buffer stores a 16-bit material index)",
                        kMaxMaterialsPerFrame, materials.size()));

    struct LightSource {
        ecs::Entity entity;
        reference::LightSample sample;
    };
    std::vector<LightSource> lights;
    for (auto [e, light, t] : world.view<ecs::Light, ecs::Transform>())
        lights.push_back({e, reference::makeLightSample(light, t)});
    std::sort(lights.begin(), lights.end(),
              [](const LightSource& a, const LightSource& b) { return a.entity.index < b.entity.index; });

    // ---- GPU copies of the assets this frame needs ------------------------------------------------
    std::vector<const GpuMesh*> gpuMeshes(sources.size());
    for (size_t i = 0; i < sources.size(); ++i) {
        std::string why;
        gpuMeshes[i] = s.cache.mesh(sources[i].renderer->mesh, *drawMesh[i], why);
        if (!gpuMeshes[i])
            return fail(fmt::format("{} (MeshRenderer): {}", entityName(sources[i].entity), why));
    }
    std::vector<rhi::TextureHandle> materialTexture(materials.size());
    if (albedo) {
        for (size_t m = 0; m < materials.size(); ++m) {
            std::string why;
            if (materials[m]->baseColorTexture == 0) {
                materialTexture[m] = s.cache.whiteTexture(why);
                if (!materialTexture[m]) return fail(why);
                continue;
            }
            const GpuTexture* t = s.cache.texture(materials[m]->baseColorTexture,
                                                  *assets.texture(materials[m]->baseColorTexture), why);
            if (!t) return fail(why);
            materialTexture[m] = t->texture;
        }
    }

    // ---- render targets -------------------------------------------------------------------------
    // From here on the previous frame's targets may change: it can no longer be read back.
    s.haveFrame = false;
    if (desc.width != s.width || desc.height != s.height) {
        for (Target& t : s.targets) s.release(t);
        s.width = desc.width;
        s.height = desc.height;
    }
    const bool drawing = !sources.empty();
    std::string why;
    for (TargetId id : {kDepth, kNormal, kMaterial, kVelocity}) {
        if (!drawing) {
            s.release(s.targets[id]);
        } else if (!s.ensureTarget(id, why)) {
            return fail(why);
        }
    }
    if (drawing && albedo) {
        if (!s.ensureTarget(kAlbedo, why)) return fail(why);
    } else {
        s.release(s.targets[kAlbedo]);
    }
    if (external) {
        s.release(s.targets[kOutput]);
    } else if (!s.ensureTarget(kOutput, why)) {
        return fail(why);
    }
    if (drawing &&
        (!s.gbufferPass.prepare(albedo, why) || !s.lightingPass.prepare(albedo, hardwareSrgb, why)))
        return fail(why);

    // ---- frame data -----------------------------------------------------------------------------
    const bool sameCamera = s.haveHistory && s.historyCamera == desc.camera;
    SceneFrameData& fd = s.frameData;
    fd = {};
    fd.frame.viewProj = viewProj;
    fd.frame.prevViewProj = sameCamera ? s.prevViewProj : viewProj;
    fd.frame.position = glm::vec4(eye, 1.0f);
    fd.frame.forward = glm::vec4(-zAxis, 0.0f);
    fd.frame.rayRight = glm::vec4(xAxis / proj[0][0], 0.0f);
    fd.frame.rayUp = glm::vec4(yAxis / proj[1][1], 0.0f);
    fd.frame.viewport = {float(desc.width), float(desc.height), 1.0f / float(desc.width),
                         1.0f / float(desc.height)};
    fd.frame.ambient = glm::vec4(desc.settings.ambient, desc.settings.exposure);
    fd.frame.background = glm::vec4(desc.settings.background, 1.0f);
    fd.frame.params = {uint32_t(lights.size()), uint32_t(desc.settings.shading),
                       uint32_t(desc.settings.toneMapper), hardwareSrgb ? 1u : 0u};
    for (const ecs::Material* m : materials) {
        GpuMaterial g;
        g.baseColor = m->baseColor;
        g.emissiveMetal = glm::vec4(m->emissive, m->metallic);
        g.params = {m->roughness, m->baseColorTexture != 0 ? 1.0f : 0.0f, 0.0f, 0.0f};
        fd.materials.push_back(g);
    }
    for (const LightSource& l : lights) {
        const reference::LightSample& ls = l.sample;
        GpuLight g;
        float type = ls.type == ecs::LightType::Directional ? 0.0f
                     : ls.type == ecs::LightType::Point     ? 1.0f
                                                            : 2.0f;
        g.positionType = glm::vec4(ls.position, type);
        g.directionRange = glm::vec4(ls.direction, ls.range);
        g.radianceRadius = glm::vec4(ls.radiance, ls.radius);
        fd.lights.push_back(g);
    }
    if (fd.lights.empty()) fd.lights.push_back(GpuLight{});  // bindable; params.x = 0 lights
    uint64_t triangles = 0;
    for (size_t i = 0; i < sources.size(); ++i) {
        GpuObject o;
        o.model = sources[i].model;
        auto prev = s.prevModels.find(sources[i].entity);
        o.prevModel = prev != s.prevModels.end() ? prev->second : o.model;
        const glm::mat3 m3(o.model);
        const glm::mat3 nm =
            std::abs(glm::determinant(m3)) > 1e-30f ? glm::inverseTranspose(m3) : glm::mat3(1.0f);
        o.normalMatrix = glm::mat4(nm);
        o.info = {drawMaterial[i], 0u, 0u, 0u};
        fd.objects.push_back(o);
        triangles += gpuMeshes[i]->indexCount / 3;
    }

    // ---- frame graph ----------------------------------------------------------------------------
    fg::FrameGraph& graph = s.graph;
    s.graphErrors.clear();
    graph.reset();
    fg::TextureRef output =
        external ? graph.importTexture("output", desc.target, desc.targetAccess, desc.targetFinalAccess)
                 : graph.importTexture("output", s.targets[kOutput].handle, s.targets[kOutput].state,
                                       rhi::Access::CopySrc);
    uint64_t transientTargetBytes = 0;
    uint64_t sceneBytes = 0;
    if (drawing) {
        const SceneBuffers scene = addSceneUploadPass(graph, fd);
        sceneBytes = scene.bytes;
        GBufferTargets gb;
        auto importTarget = [&](TargetId id) {
            return graph.importTexture(kTargets[id].name, s.targets[id].handle, s.targets[id].state,
                                       rhi::Access::ShaderSampled);
        };
        gb.depth = importTarget(kDepth);
        gb.normal = importTarget(kNormal);
        gb.material = importTarget(kMaterial);
        gb.velocity = importTarget(kVelocity);
        if (albedo) gb.albedo = importTarget(kAlbedo);

        // Each mesh's buffers and each texture imported once.
        std::unordered_map<const GpuMesh*, std::pair<fg::BufferRef, fg::BufferRef>> meshRefs;
        std::unordered_map<uint32_t, fg::TextureRef> textureRefs;
        std::vector<MeshDraw> draws;
        draws.reserve(sources.size());
        for (size_t i = 0; i < sources.size(); ++i) {
            const GpuMesh* gm = gpuMeshes[i];
            auto it = meshRefs.find(gm);
            if (it == meshRefs.end()) {
                const std::string base = fmt::format("mesh.{:016x}", sources[i].renderer->mesh);
                it = meshRefs
                         .emplace(gm, std::make_pair(graph.importBuffer(base + ".vertices", gm->vertices,
                                                                        rhi::Access::VertexRead),
                                                     graph.importBuffer(base + ".indices", gm->indices,
                                                                        rhi::Access::IndexRead)))
                         .first;
            }
            MeshDraw d;
            d.vertices = it->second.first;
            d.indices = it->second.second;
            d.indexCount = gm->indexCount;
            d.objectIndex = uint32_t(i);
            if (albedo) {
                const rhi::TextureHandle tex = materialTexture[drawMaterial[i]];
                auto t = textureRefs.find(tex.value);
                if (t == textureRefs.end()) {
                    const ecs::Material* m = materials[drawMaterial[i]];
                    const std::string name = m->baseColorTexture != 0
                                                 ? fmt::format("texture.{:016x}", m->baseColorTexture)
                                                 : std::string("texture.white");
                    t = textureRefs
                            .emplace(tex.value, graph.importTexture(name, tex, rhi::Access::ShaderSampled))
                            .first;
                }
                d.baseColor = t->second;
            }
            draws.push_back(d);
        }
        transientTargetBytes +=
            s.gbufferPass.add(graph, scene, gb, std::move(draws), desc.width, desc.height);
        s.lightingPass.add(graph, scene, gb, output, hardwareSrgb, desc.width, desc.height);
    } else {
        const glm::vec3 bg = desc.settings.background * desc.settings.exposure;
        std::array<float, 4> encoded{};
        // An sRGB target encodes on write (clears included): give it the linear value.
        for (int c = 0; c < 3; ++c) {
            const float mapped = reference::toneMap(desc.settings.toneMapper, bg[c]);
            encoded[size_t(c)] = hardwareSrgb ? mapped : reference::srgbEncode(mapped);
        }
        encoded[3] = 1.0f;
        s.lightingPass.addBackground(graph, output, encoded);
    }

    if (!graph.compile()) return fail("frame graph compilation failed: " + s.graphErrors);
    s.graphviz = graph.toGraphviz();
    rhi::CommandList& cmd = s.device.beginCommandList("scene.frame");
    graph.execute(cmd);
    s.device.submit(cmd);
    std::vector<fg::PassTiming> timings = graph.collectTimings();

    // States the frame left the persistent targets in.
    if (!external) s.targets[kOutput].state = rhi::Access::CopySrc;
    if (drawing) {
        for (TargetId id : {kDepth, kNormal, kMaterial, kVelocity})
            s.targets[id].state = rhi::Access::ShaderSampled;
        if (albedo) s.targets[kAlbedo].state = rhi::Access::ShaderSampled;
    }
    s.haveFrame = true;
    s.lastOwnOutput = !external;
    s.lastGbuffer = drawing;
    s.lastAlbedo = drawing && albedo;

    // Velocity history for the next frame.
    s.haveHistory = true;
    s.historyCamera = desc.camera;
    s.prevViewProj = viewProj;
    s.prevModels.clear();
    for (const DrawSource& src : sources) s.prevModels[src.entity] = src.model;

    FrameStats& st = s.stats;
    st = {};
    st.passes = std::move(timings);
    st.memory.meshBuffers = s.cache.meshBytes();
    st.memory.textures = s.cache.textureBytes();
    st.memory.sceneBuffers = sceneBytes;
    st.memory.renderTargets = s.targetBytes() + transientTargetBytes;
    st.drawCalls = uint32_t(sources.size());
    st.triangles = triangles;
    st.lights = uint32_t(lights.size());
    st.materials = uint32_t(materials.size());

    if (!s.graphErrors.empty()) return fail("frame graph reported errors: " + s.graphErrors);
    return true;
}

bool SceneRenderer::readPixels(ImageRGBA8& out, std::string& error) {
    Impl& s = *m_impl;
    if (!s.haveFrame) {
        error = "scene renderer: readPixels: no frame has been rendered";
        return false;
    }
    if (!s.lastOwnOutput) {
        error = "scene renderer: readPixels: the last frame was rendered into an external target";
        return false;
    }
    const Target& t = s.targets[kOutput];
    std::vector<uint8_t> texels;
    if (!s.device.readTexture(t.handle, {}, t.state, texels) ||
        texels.size() != size_t(s.width) * s.height * 4) {
        error = "scene renderer: readPixels: reading back the output texture failed";
        return false;
    }
    out.width = s.width;
    out.height = s.height;
    out.pixels = std::move(texels);
    return true;
}

bool SceneRenderer::readTarget(const std::string& name, std::vector<uint8_t>& texels, rhi::Format& format,
                               std::string& error) {
    Impl& s = *m_impl;
    for (uint32_t id = 0; id < kAlbedo + 1; ++id) {
        if (name != kTargets[id].name) continue;
        const bool present = s.haveFrame && s.lastGbuffer && (id != kAlbedo || s.lastAlbedo);
        if (!present) {
            error = "scene renderer: readTarget: '" + name + "' was not part of the last frame";
            return false;
        }
        const Target& t = s.targets[id];
        if (!s.device.readTexture(t.handle, {}, t.state, texels)) {
            error = "scene renderer: readTarget: reading back '" + name + "' failed";
            return false;
        }
        format = kTargets[id].format;
        return true;
    }
    error = "scene renderer: readTarget: unknown target '" + name +
            "' (gbuffer.depth, gbuffer.normal, gbuffer.material, gbuffer.velocity, gbuffer.albedo)";
    return false;
}

const FrameStats& SceneRenderer::lastFrameStats() const { return m_impl->stats; }

std::string SceneRenderer::lastFrameGraphviz() const { return m_impl->graphviz; }

void SceneRenderer::collectAssets(const assets::AssetManager& assets) { m_impl->cache.collect(assets); }

}  // namespace penumbra::render
