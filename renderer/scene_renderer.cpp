// The scene renderer: gathers the frame from the World (camera, visible MeshRenderers, lights,
// the materials they use), makes sure the GPU copies of meshes and textures exist, keeps the
// persistent G-buffer targets and the velocity history, and orders the feature modules of
// renderer/features/ (scene_upload -> mesh_gbuffer -> lighting or debug_view) on one frame graph.
// render() is an orchestration of steps, each a function below: check the frame and the camera,
// gather draws/materials/lights, make GPU copies of assets, keep the targets, fill the frame data,
// build the graph from the modules, submit and record history and statistics.
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
#include <unordered_set>
#include <utility>

#include <fmt/format.h>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "engine/core/log.h"
#include "renderer/core/gpu_cache.h"
#include "renderer/core/targets.h"
#include "renderer/features/debug_view.h"
#include "renderer/features/effects.h"
#include "renderer/features/gpu_scene.h"
#include "renderer/features/lighting.h"
#include "renderer/features/lighting_reference.h"
#include "renderer/features/mesh_gbuffer.h"
#include "renderer/features/post_output.h"
#include "renderer/features/scene_upload.h"
#include "renderer/features/sdf_atlas.h"
#include "renderer/features/sdf_box_trace.h"
#include "renderer/features/sdf_cull.h"
#include "renderer/features/sdf_effects_cull.h"
#include "renderer/features/sdf_scene.h"
#include "renderer/features/sdf_surface.h"
#include "renderer/features/sdf_trace.h"
#include "renderer/features/sdf_world_cache.h"
#include "renderer/features/taa.h"

namespace penumbra::render {
namespace {

constexpr uint32_t kMaxMaterialsPerFrame = 65536;

enum TargetId : uint32_t {
    kDepth,
    kNormal,
    kMaterial,
    kVelocity,
    kAlbedo,
    kAux,
    kShadow,
    kAo,
    kThickness,
    kReflection,
    kOutput,
    kSceneColor,  // the linear colour lighting writes when TAA or motion blur follow
    kTargetCount
};

struct TargetInfo {
    const char* name;
    rhi::Format format;
};
constexpr TargetInfo kTargets[kTargetCount] = {
    {"gbuffer.depth", rhi::Format::R32_FLOAT},      {"gbuffer.normal", rhi::Format::RG16_FLOAT},
    {"gbuffer.material", rhi::Format::RGBA8_UNORM}, {"gbuffer.velocity", rhi::Format::RG16_FLOAT},
    {"gbuffer.albedo", rhi::Format::RGBA8_UNORM},   {"gbuffer.aux", rhi::Format::RG32_FLOAT},
    {"effects.shadow", rhi::Format::R8_UNORM},      {"effects.ao", rhi::Format::RGBA8_UNORM},
    {"effects.thickness", rhi::Format::R16_FLOAT},  {"effects.reflection", rhi::Format::RGBA16_FLOAT},
    {"output", rhi::Format::RGBA8_UNORM},           {"scene.color", rhi::Format::RGBA16_FLOAT},
};

// A render target owned by the renderer; the frame graph tracks its state (importPersistent).
struct Target {
    rhi::TextureHandle handle;
    uint64_t bytes = 0;
};

struct DrawSource {
    ecs::Entity entity;
    const ecs::MeshRenderer* renderer = nullptr;
    glm::mat4 model{1.0f};
};

// A visible SdfRenderer that will be traced this frame (or, occluderOnly, seen by the effects only).
struct SdfSource {
    ecs::Entity entity;
    const ecs::SdfRenderer* renderer = nullptr;
    bool occluder = false;  // SdfRenderer::occluderOnly: a rasterized mesh's field (--mesh-sdf occlusion)
    glm::mat4 model{1.0f};
    float sigma = 1.0f;  // smallest singular value of the model's 3x3 part
    uint32_t material = 0;
    const sdf::ShapeProgram* program = nullptr;  // analytic shapes, or
    const sdf::PsdfAsset* field = nullptr;       // a distance field
};

struct LightSource {
    ecs::Entity entity;
    reference::LightSample sample;
    bool castShadows = false;
    float angularRadius = 0.0f;  // directional lights, radians
    int32_t shadowLayer = -1;    // its layer of effects.shadow (-1: unshadowed this frame)
};

// The camera of a frame, without scale: forward = -zAxis, right = xAxis, up = yAxis.
struct CameraSetup {
    glm::vec3 xAxis{1, 0, 0}, yAxis{0, 1, 0}, zAxis{0, 0, 1}, eye{0.0f};
    glm::mat4 view{1.0f}, proj{1.0f}, viewProj{1.0f};  // proj and viewProj include the TAA jitter
    glm::mat4 unjitteredProj{1.0f};
    float nearPlane = 0.1f;
    float farPlane = 1.0f;
};

// What a frame draws, gathered from the World and the asset manager.
struct FrameGather {
    std::vector<DrawSource> sources;
    std::vector<const ecs::Material*> materials;
    std::vector<uint32_t> drawMaterial;  // per source: index into materials
    std::vector<const assets::MeshData*> drawMesh;
    std::vector<const GpuMesh*> gpuMeshes;
    std::vector<rhi::TextureHandle> materialTexture;  // per material, albedo frames only
    std::vector<rhi::TextureHandle> materialNormal;   // per material: normal maps of traced SDF materials
    std::vector<LightSource> lights;
    std::vector<SdfSource> sdfs;  // traced ones, then occluders, each in ascending entity index
    uint32_t tracedSdfs = 0;      // sdfs[0, tracedSdfs) are traced
    EffectsDesc effects;          // what the effect passes compute this frame
    bool albedo = false;          // some material has a base-colour texture
    bool hardwareSrgb = false;
    bool external = false;
    bool taa = false;        // TAA runs (renderer/features/taa.h)
    bool post = false;       // TAA or motion blur: lighting writes scene.color, post_output the output
    glm::vec2 jitter{0.0f};  // this frame's sub-pixel jitter in pixels (TAA only)
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
    scene::TraceMode lastTraceMode = scene::TraceMode::Fullscreen;  // the mode buildGraph ran
    SdfBoxTraceReport lastBoxTrace;                                 // its draws (box mode)
    bool lastTraceObjectsUniform = false;  // sdf_trace read the objects as a uniform block
    double lastBoxCoverage = 0.0;          // boxCoverage of the traced objects
    rhi::Device& device;
    std::string graphErrors;
    fg::FrameGraph graph;
    GpuCache gpuCache;
    GpuAssetCache cache;
    Blackboard board;

    uint32_t width = 0, height = 0;
    Target targets[kTargetCount];

    // velocity history
    bool haveHistory = false;
    ecs::Entity historyCamera;
    glm::mat4 prevViewProj{1.0f};
    std::unordered_map<ecs::Entity, glm::mat4> prevModels;
    std::unordered_set<uint64_t> warnedSdfs;  // SDF entities already warned about (once each)
    SdfSceneData sdfData;                     // read by sdf_upload's execute
    SdfAtlas atlas;                           // the fields of the frame's SdfRenderers
    SdfWorldCache worldCache;                 // clipmapped world SDF + id field (issue 13)
    SdfSceneStore sdfStore;                   // the persistent SDF object array (delta updates)
    uint32_t shadowLayers = 0;                // layers of targets[kShadow]
    uint32_t warnedShadowWidth = 0;           // frame width last warned about for too many shadow layers
    uint32_t frameIndex = 0;
    TaaHistory taa;              // the TAA history (only while frames run TAA)
    glm::vec2 lastJitter{0.0f};  // the jitter of prevViewProj

    // the last frame
    SceneFrameData frameData;  // read by scene_upload's execute
    FrameStats stats;
    std::vector<fg::FrameTimings> completedTimings;      // polled, not yet taken
    uint64_t submitted[fg::kTimingFramesInFlight] = {};  // submission serial per frame slot
    uint64_t lastFrameNumber = 0;                        // frame-graph number of the last frame
    uint64_t statsFrameNumber = 0;                       // the frame stats.passes belongs to
    std::string graphviz;
    bool haveFrame = false;
    bool lastOwnOutput = false;
    bool lastGbuffer = false;
    bool lastAlbedo = false;
    bool lastAux = false;
    bool lastEffect[kTargetCount] = {};  // effect targets written by the last frame
    // Buffers the last frame kept for readBuffer (tests): name -> handle, bytes.
    std::unordered_map<std::string, std::pair<rhi::BufferHandle, uint64_t>> keptBuffers;

    explicit Impl(rhi::Device& d)
        : device(d),
          graph(d,
                [this](rhi::LogSeverity s, std::string_view msg) {
                    if (s == rhi::LogSeverity::Error) graphErrors.append(msg).append("\n");
                }),
          gpuCache(d),
          cache(d),
          atlas(d),
          worldCache(d),
          sdfStore(d),
          taa(d) {}

    ~Impl() {
        for (Target& t : targets) release(t);
        taa.release(graph);
        sdfStore.release(graph);
    }

    void release(Target& t) {
        if (t.handle) {
            graph.forgetPersistent(t.handle);
            device.destroy(t.handle);
        }
        t = {};
    }

    bool ensureTarget(TargetId id, std::string& error) {
        Target& t = targets[id];
        if (t.handle) return true;
        using TU = rhi::TextureUsage;
        // G-buffer targets are also storage images: the SDF trace (compute) reads and writes them.
        const TU usage =
            TU::ColorTarget | TU::Sampled | TU::CopySrc | (id == kOutput ? TU::None : TU::Storage);
        const uint32_t w = id == kShadow ? width * std::max(shadowLayers, 1u) : width;
        rhi::TextureDesc d = renderTargetDesc(kTargets[id].format, w, height, kTargets[id].name, usage);
        t.handle = device.createTexture(d);
        if (!t.handle) {
            error =
                fmt::format("creating the {}x{} render target '{}' failed", width, height, kTargets[id].name);
            return false;
        }
        t.bytes = rhi::textureBytes(d);
        return true;
    }

    // What the frame's effects ran and hold (call after buildGraph: reads EffectsLowRes).
    EffectsReport effectsReport(const FrameGather& g) const {
        EffectsReport r;
        if (!lastEffect[kShadow] && !lastEffect[kAo] && !lastEffect[kThickness] && !lastEffect[kReflection])
            return r;
        r.shadowLayers = lastEffect[kShadow] ? g.effects.shadowLayers : 0;
        r.ao = lastEffect[kAo] ? scene::toString(g.effects.ao.variant) : "off";
        r.thickness = lastEffect[kThickness];
        r.reflection = lastEffect[kReflection];
        for (TargetId id : {kShadow, kAo, kThickness, kReflection}) r.targetBytes += targets[id].bytes;
        if (const EffectsLowRes* low = board.find<EffectsLowRes>()) {
            if (low->shadow.isValid())
                r.lowResBytes += uint64_t(low->shadowWidth) * r.shadowLayers * low->shadowHeight;  // R8
            if (low->ao.isValid()) r.lowResBytes += uint64_t(low->aoWidth) * low->aoHeight * 4;    // RGBA8
        }
        return r;
    }

    uint64_t targetBytes() const {
        uint64_t total = 0;
        for (const Target& t : targets) total += t.bytes;
        return total;
    }

    bool checkFrame(const ecs::World& world, const FrameDesc& desc, FrameGather& g, std::string& error);
    bool setupCamera(const ecs::World& world, const FrameDesc& desc, CameraSetup& cam, std::string& error);
    bool gather(const ecs::World& world, const assets::AssetManager& assets, FrameGather& g,
                std::string& error);
    bool gatherSdfs(const ecs::World& world, const assets::AssetManager& assets, FrameGather& g,
                    std::string& error);
    bool uploadAssets(const assets::AssetManager& assets, FrameGather& g, std::string& error);
    bool prepareTargets(const FrameDesc& desc, const FrameGather& g, std::string& error);
    bool uploadFields(FrameGather& g, std::string& error);
    void planEffects(const FrameDesc& desc, FrameGather& g);
    bool preparePost(const FrameDesc& desc, FrameGather& g, CameraSetup& cam, std::string& error);
    void fillFrameData(const FrameDesc& desc, const CameraSetup& cam, const FrameGather& g);
    void fillSdfData(const FrameGather& g);
    uint64_t buildGraph(const FrameDesc& desc, const CameraSetup& cam, const FrameGather& g);
    void addWorldCache(FrameContext& fc, const FrameDesc& desc, const CameraSetup& cam);
    float debugDepthRange(const CameraSetup& cam, const FrameGather& g) const;
    std::vector<MeshDraw> importDraws(const FrameGather& g);
    // Material textures, each imported into this frame's graph once (meshes and sdf_surface share them).
    std::unordered_map<uint64_t, fg::TextureRef> textureRefs;
    fg::TextureRef importMaterialTexture(rhi::TextureHandle tex, assets::AssetId id);
    bool uploadSdfNormalMaps(const assets::AssetManager& assets, FrameGather& g, std::string& error);
    std::vector<SdfSurfaceMaterial> sdfSurfaceMaterials(const FrameGather& g);
    void finishFrame(const FrameDesc& desc, const CameraSetup& cam, const FrameGather& g,
                     uint64_t transientBytes);
};

SceneRenderer::SceneRenderer(rhi::Device& device) : m_impl(std::make_unique<Impl>(device)) {}

SceneRenderer::~SceneRenderer() = default;

bool SceneRenderer::render(const ecs::World& world, const assets::AssetManager& assets, const FrameDesc& desc,
                           std::string& error) {
    Impl& s = *m_impl;
    error.clear();
    FrameGather g;
    CameraSetup cam;
    std::string why;
    if (!s.checkFrame(world, desc, g, why) || !s.setupCamera(world, desc, cam, why) ||
        !s.gather(world, assets, g, why) || !s.uploadAssets(assets, g, why) ||
        (s.planEffects(desc, g), !s.preparePost(desc, g, cam, why)) || !s.prepareTargets(desc, g, why)) {
        error = "scene renderer: " + why;
        return false;
    }
    s.fillFrameData(desc, cam, g);
    s.graphErrors.clear();
    const uint64_t transientBytes = s.buildGraph(desc, cam, g);
    if (!s.graph.compile()) {
        error = "scene renderer: frame graph compilation failed: " + s.graphErrors;
        return false;
    }
    s.graphviz = s.graph.toGraphviz();
    // At most kTimingFramesInFlight - 1 frames run ahead of the GPU: the frame that last used this
    // frame's slot (timestamps, per-frame buffers) has finished, so nothing below waits for it.
    uint64_t& slotSerial = s.submitted[s.graph.frameNumber() % fg::kTimingFramesInFlight];
    if (slotSerial) s.device.waitForSubmission(slotSerial);
    rhi::CommandList& cmd = s.device.beginCommandList("scene.frame");
    s.graph.execute(cmd);
    slotSerial = s.device.submit(cmd);
    s.lastFrameNumber = s.graph.frameNumber();
    s.gpuCache.endFrame();
    s.finishFrame(desc, cam, g, transientBytes);
    if (!s.graphErrors.empty()) {
        error = "scene renderer: frame graph reported errors: " + s.graphErrors;
        return false;
    }
    return true;
}

// The frame size, the camera entity and an external target.
bool SceneRenderer::Impl::checkFrame(const ecs::World& world, const FrameDesc& desc, FrameGather& g,
                                     std::string& error) {
    const uint32_t maxSize = std::max<uint32_t>(device.info().limits.maxTextureSize2D, 1);
    if (desc.width == 0 || desc.height == 0 || desc.width > maxSize || desc.height > maxSize) {
        error = fmt::format("frame size {}x{} is invalid (1..{} per side)", desc.width, desc.height, maxSize);
        return false;
    }
    if (desc.camera.isNull()) {
        error = "no camera: FrameDesc::camera is the null entity";
        return false;
    }
    if (!world.alive(desc.camera) || !world.get<ecs::Camera>(desc.camera) ||
        !world.get<ecs::Transform>(desc.camera)) {
        error =
            fmt::format("no camera: {} (FrameDesc::camera) {}", entityName(desc.camera),
                        !world.alive(desc.camera) ? "is not alive" : "does not have Camera and Transform");
        return false;
    }
    g.external = desc.target.isValid();
    if (!g.external) return true;
    // An RGBA8_SRGB target (e.g. the GL window backbuffer) encodes in hardware; RGBA8_UNORM targets
    // get the exact sRGB OETF in the shader.
    const rhi::TextureDesc* td = device.describe(desc.target);
    if (!td) {
        error = "FrameDesc::target is not a live texture";
        return false;
    }
    if ((td->format != rhi::Format::RGBA8_UNORM && td->format != rhi::Format::RGBA8_SRGB) ||
        td->width != desc.width || td->height != desc.height ||
        !any(td->usage & rhi::TextureUsage::ColorTarget)) {
        error = fmt::format(
            "FrameDesc::target '{}' must be an RGBA8_UNORM or RGBA8_SRGB colour target of {}x{} (it is "
            "{} {}x{})",
            td->debugName, desc.width, desc.height, rhi::formatInfo(td->format).name, td->width, td->height);
        return false;
    }
    g.hardwareSrgb = td->format == rhi::Format::RGBA8_SRGB;
    return true;
}

// Camera basis without scale (Gram-Schmidt), view and projection (Vulkan clip space).
bool SceneRenderer::Impl::setupCamera(const ecs::World& world, const FrameDesc& desc, CameraSetup& cam,
                                      std::string& error) {
    const ecs::Camera& camera = *world.get<ecs::Camera>(desc.camera);
    if (!std::isfinite(camera.fovY) || camera.fovY <= 0.0f || camera.fovY >= 3.14159f ||
        !std::isfinite(camera.nearPlane) || !std::isfinite(camera.farPlane) || camera.nearPlane <= 0.0f ||
        camera.farPlane <= camera.nearPlane) {
        error = fmt::format("camera {}: fovY {} must be in (0, pi) and 0 < near {} < far {}",
                            entityName(desc.camera), camera.fovY, camera.nearPlane, camera.farPlane);
        return false;
    }
    const glm::mat4& cw = world.get<ecs::Transform>(desc.camera)->worldMatrix;
    if (!finite(cw)) {
        error = fmt::format("camera {}: world matrix is not finite", entityName(desc.camera));
        return false;
    }
    glm::vec3 zAxis = glm::vec3(cw[2]);
    glm::vec3 xAxis = glm::vec3(cw[0]);
    if (glm::length(zAxis) >= 1e-12f && glm::length(xAxis) >= 1e-12f) {
        zAxis = glm::normalize(zAxis);
        xAxis = xAxis - zAxis * glm::dot(xAxis, zAxis);
    }
    if (glm::length(zAxis) < 1e-12f || glm::length(xAxis) < 1e-12f) {
        error = fmt::format("camera {}: world matrix is degenerate", entityName(desc.camera));
        return false;
    }
    cam.zAxis = zAxis;
    cam.xAxis = glm::normalize(xAxis);
    cam.yAxis = glm::cross(cam.zAxis, cam.xAxis);
    cam.eye = glm::vec3(cw[3]);
    const glm::mat4 rigid(glm::vec4(cam.xAxis, 0), glm::vec4(cam.yAxis, 0), glm::vec4(cam.zAxis, 0),
                          glm::vec4(cam.eye, 1));
    cam.view = glm::affineInverse(rigid);
    cam.proj = glm::perspectiveRH_ZO(camera.fovY, float(desc.width) / float(desc.height), camera.nearPlane,
                                     camera.farPlane);
    cam.proj[1][1] *= -1.0f;  // Vulkan clip space: NDC y = -1 is image row 0
    cam.viewProj = cam.proj * cam.view;
    cam.unjitteredProj = cam.proj;
    cam.nearPlane = camera.nearPlane;
    cam.farPlane = camera.farPlane;
    return true;
}

// Visible MeshRenderers and SdfRenderers (each in ascending entity index), the materials they use
// (in order of first use: meshes first, then SDF objects) and the lights.
bool SceneRenderer::Impl::gather(const ecs::World& world, const assets::AssetManager& assets, FrameGather& g,
                                 std::string& error) {
    for (auto [e, mr, t] : world.view<ecs::MeshRenderer, ecs::Transform>())
        if (mr.visible) g.sources.push_back({e, &mr, t.worldMatrix});
    std::sort(g.sources.begin(), g.sources.end(),
              [](const DrawSource& a, const DrawSource& b) { return a.entity.index < b.entity.index; });
    static const ecs::Material kDefaultMaterial{};
    std::unordered_map<assets::AssetId, uint32_t> materialIndex;
    // The frame's index of material asset `id` (0: the default material), added on first use.
    auto materialSlot = [&](assets::AssetId id, const std::string& who, uint32_t& slot) {
        auto it = materialIndex.find(id);
        if (it == materialIndex.end()) {
            const ecs::Material* m = id == 0 ? &kDefaultMaterial : assets.material(id);
            if (!m) {
                error = fmt::format("{}: material asset {:016x} is not loaded", who, id);
                return false;
            }
            if (m->baseColorTexture != 0) {
                if (!assets.texture(m->baseColorTexture)) {
                    error = fmt::format("{}: material {:016x}: base-colour texture {:016x} is not loaded",
                                        who, id, m->baseColorTexture);
                    return false;
                }
                g.albedo = true;
            }
            it = materialIndex.emplace(id, uint32_t(g.materials.size())).first;
            g.materials.push_back(m);
        }
        slot = it->second;
        return true;
    };
    g.drawMaterial.resize(g.sources.size());
    g.drawMesh.resize(g.sources.size());
    for (size_t i = 0; i < g.sources.size(); ++i) {
        const DrawSource& src = g.sources[i];
        const ecs::MeshRenderer& mr = *src.renderer;
        const std::string who = entityName(src.entity) + " (MeshRenderer)";
        g.drawMesh[i] = mr.mesh == 0 ? nullptr : assets.mesh(mr.mesh);
        if (!g.drawMesh[i]) {
            error = mr.mesh == 0 ? who + ": no mesh asset (id 0)"
                                 : fmt::format("{}: mesh asset {:016x} is not loaded", who, mr.mesh);
            return false;
        }
        if (!finite(src.model)) {
            error = who + ": world matrix is not finite";
            return false;
        }
        if (!materialSlot(mr.material, who, g.drawMaterial[i])) return false;
    }
    if (!gatherSdfs(world, assets, g, error)) return false;
    for (SdfSource& s : g.sdfs)
        if (!materialSlot(s.renderer->material, entityName(s.entity) + " (SdfRenderer)", s.material))
            return false;
    if (g.materials.size() > kMaxMaterialsPerFrame) {
        error = fmt::format(
            "more than {} materials in one frame ({} used by the visible MeshRenderers and SdfRenderers; the "
            "G-buffer stores a 16-bit material index)",
            kMaxMaterialsPerFrame, g.materials.size());
        return false;
    }
    for (auto [e, light, t] : world.view<ecs::Light, ecs::Transform>())
        g.lights.push_back({e, reference::makeLightSample(light, t), light.castShadows,
                            light.type == ecs::LightType::Directional ? light.angularRadius : 0.0f});
    std::sort(g.lights.begin(), g.lights.end(),
              [](const LightSource& a, const LightSource& b) { return a.entity.index < b.entity.index; });
    return true;
}

// Visible SdfRenderers with a usable transform. An object whose transform cannot be traced (zero,
// negative or non-finite scale, a non-finite or singular world matrix) or that has no SDF asset
// (a mesh bake that did not run) is skipped with one warning naming it; the frame still renders.
// An SDF asset id that names nothing loaded fails the frame (as a missing mesh does).
bool SceneRenderer::Impl::gatherSdfs(const ecs::World& world, const assets::AssetManager& assets,
                                     FrameGather& g, std::string& error) {
    for (auto [e, sr, t] : world.view<ecs::SdfRenderer, ecs::Transform>()) {
        if (!sr.visible) continue;
        SdfSource s;
        s.entity = e;
        s.renderer = &sr;
        s.occluder = sr.occluderOnly;
        s.model = t.worldMatrix;
        const ecs::Name* name = world.get<ecs::Name>(e);
        const std::string who =
            (name && !name->value.empty() ? "'" + name->value + "' (" + entityName(e) + ")" : entityName(e)) +
            " (SdfRenderer)";
        auto skip = [&](const std::string& why) {
            if (warnedSdfs.insert(uint64_t(e.index) << 32 | e.generation).second)
                log::warn("{}: {}; the object is not drawn", who, why);
        };
        if (sr.sdf == 0) {
            skip(std::string("has no SDF asset (source '") + ecs::sdfSourceName(sr.source) + "')");
            continue;
        }
        s.program = assets.shapeProgram(sr.sdf);
        s.field = s.program ? nullptr : assets.sdfField(sr.sdf);
        if (!s.program && !s.field) {
            error = fmt::format("{}: SDF asset {:016x} is not loaded", who, sr.sdf);
            return false;
        }
        const glm::vec3 sc = t.scale;
        if (!std::isfinite(sc.x) || !std::isfinite(sc.y) || !std::isfinite(sc.z) || sc.x <= 0.0f ||
            sc.y <= 0.0f || sc.z <= 0.0f) {
            skip(fmt::format("scale ({}, {}, {}) is zero, negative or not finite", sc.x, sc.y, sc.z));
            continue;
        }
        s.sigma = finite(s.model) ? smallestSingularValue(glm::mat3(s.model)) : 0.0f;
        if (!finite(s.model) || !(s.sigma > 1e-20f) || glm::determinant(glm::mat3(s.model)) <= 0.0f) {
            skip("world matrix is not finite, singular or mirrored");
            continue;
        }
        g.sdfs.push_back(s);
    }
    std::sort(g.sdfs.begin(), g.sdfs.end(), [](const SdfSource& a, const SdfSource& b) {
        return a.occluder != b.occluder ? b.occluder : a.entity.index < b.entity.index;
    });
    g.tracedSdfs =
        uint32_t(std::count_if(g.sdfs.begin(), g.sdfs.end(), [](const SdfSource& s) { return !s.occluder; }));
    return true;
}

// The field atlas holds exactly the fields this frame draws (one slot per asset).
bool SceneRenderer::Impl::uploadFields(FrameGather& g, std::string& error) {
    std::vector<std::pair<assets::AssetId, const sdf::PsdfAsset*>> fields;
    std::unordered_set<assets::AssetId> listed;
    for (const SdfSource& s : g.sdfs)
        if (s.field && listed.insert(s.renderer->sdf).second) fields.emplace_back(s.renderer->sdf, s.field);
    if (fields.empty() && !atlas.texture()) return true;
    std::string why;
    if (!atlas.update(fields, why)) {
        error = "SDF field atlas: " + why;
        return false;
    }
    return true;
}

// Which effects run (renderer/features/effects.h): they trace the frame's SDF objects, so a frame
// without any runs none; shadows for the lights with castShadows (one layer each, in light order);
// the thickness and reflection passes only when a material of the frame asks for them. A debug
// view other than the effects' own needs none.
void SceneRenderer::Impl::planEffects(const FrameDesc& desc, FrameGather& g) {
    EffectsDesc& fx = g.effects;
    fx = resolveEffects(desc.settings);
    const DebugView view = frameDebugView(desc.debugView, desc.settings);
    const bool wanted = view == DebugView::None || view == DebugView::Ao || view == DebugView::Shadow ||
                        view == DebugView::BentNormal || view == DebugView::Thickness;
    const bool on = wanted && !g.sdfs.empty();
    // The shadow strip holds one frame-wide column block per shadowed light: at most
    // maxTextureSize2D / width of them; further lights are unshadowed (one warning per frame size).
    const uint32_t maxLayers = std::max<uint32_t>(device.info().limits.maxTextureSize2D, 1) / desc.width;
    uint32_t layers = 0, dropped = 0;
    for (LightSource& l : g.lights) {
        const bool shadowed = on && fx.shadows.enabled && l.castShadows;
        l.shadowLayer = shadowed && layers < maxLayers ? int32_t(layers++) : -1;
        dropped += shadowed && l.shadowLayer < 0;
    }
    if (dropped && warnedShadowWidth != desc.width) {
        warnedShadowWidth = desc.width;
        log::warn(
            "{} shadowed light(s) beyond the first {} are drawn unshadowed: a {}-pixel-wide frame "
            "fits {} shadow layers in a {}-texel texture",
            dropped, layers, desc.width, maxLayers, device.info().limits.maxTextureSize2D);
    }
    fx.shadowLayers = layers;
    if (!on) fx.ao.variant = scene::AoVariant::Off;
    bool thickness = false, reflection = false;
    for (const ecs::Material* m : g.materials) {
        thickness = thickness || m->subsurface > 0.0f;
        reflection = reflection || (m->reflections && m->roughness <= fx.reflections.roughnessCutoff);
    }
    fx.thickness = on && thickness;
    fx.reflection = on && reflection;
}

// TAA and motion blur run on lit frames that draw something (a debug view or an empty frame writes
// the output directly). TAA: the history restarts on a camera change or FrameDesc::resetHistory
// (and, in TaaHistory::begin, on a size change or after frames without TAA, which free it); the
// jitter phase is the renderer's frame index (not time), so a sequence renders the same every run. The
// projection moves the image by -jitter, so pixel p samples p + 0.5 + jitter as the traced rays do.
bool SceneRenderer::Impl::preparePost(const FrameDesc& desc, FrameGather& g, CameraSetup& cam,
                                      std::string& error) {
    const bool drawing = !g.sources.empty() || g.tracedSdfs > 0;
    const bool lit = drawing && frameDebugView(desc.debugView, desc.settings) == DebugView::None;
    g.taa = lit && desc.settings.taa;
    g.post = g.taa || (lit && desc.settings.motionBlur.enabled);
    if (!g.taa) {
        taa.release(graph);
        return true;
    }
    const bool sameCamera = haveHistory && historyCamera == desc.camera;
    if (!taa.begin(graph, desc.width, desc.height, desc.resetHistory || !sameCamera, error)) return false;
    g.jitter = taaJitter(frameIndex);
    cam.proj[2][0] += 2.0f * g.jitter.x / float(desc.width);
    cam.proj[2][1] += 2.0f * g.jitter.y / float(desc.height);
    cam.viewProj = cam.proj * cam.view;
    return true;
}

// GPU copies of the meshes and (albedo frames) textures this frame needs.
bool SceneRenderer::Impl::uploadAssets(const assets::AssetManager& assets, FrameGather& g,
                                       std::string& error) {
    g.gpuMeshes.resize(g.sources.size());
    for (size_t i = 0; i < g.sources.size(); ++i) {
        std::string why;
        g.gpuMeshes[i] = cache.mesh(g.sources[i].renderer->mesh, *g.drawMesh[i], why);
        if (!g.gpuMeshes[i]) {
            error = fmt::format("{} (MeshRenderer): {}", entityName(g.sources[i].entity), why);
            return false;
        }
    }
    if (!uploadFields(g, error)) return false;
    if (!uploadSdfNormalMaps(assets, g, error)) return false;
    if (!g.albedo) return true;
    g.materialTexture.resize(g.materials.size());
    for (size_t m = 0; m < g.materials.size(); ++m) {
        const assets::AssetId id = g.materials[m]->baseColorTexture;
        if (id == 0) {
            g.materialTexture[m] = cache.whiteTexture(error);
        } else if (const GpuTexture* t = cache.texture(id, *assets.texture(id), error)) {
            g.materialTexture[m] = t->texture;
        }
        if (!g.materialTexture[m]) return false;
    }
    return true;
}

// The persistent targets this frame writes (G-buffer only when something is drawn, albedo only
// when a material is textured, the own output only without an external target).
bool SceneRenderer::Impl::prepareTargets(const FrameDesc& desc, const FrameGather& g, std::string& error) {
    // From here on the previous frame's targets may change: it can no longer be read back.
    haveFrame = false;
    if (desc.width != width || desc.height != height) {
        for (Target& t : targets) release(t);
        width = desc.width;
        height = desc.height;
    }
    const bool drawing = !g.sources.empty() || g.tracedSdfs > 0;
    if (g.effects.shadowLayers != shadowLayers) {
        release(targets[kShadow]);
        shadowLayers = g.effects.shadowLayers;
    }
    const EffectsDesc& fx = g.effects;
    for (uint32_t i = 0; i < kTargetCount; ++i) {
        const TargetId id = TargetId(i);
        const bool needed =
            id == kOutput       ? !g.external
            : id == kSceneColor ? g.post
            : id == kAlbedo     ? drawing && g.albedo
            : id == kAux ? drawing && frameNeedsAux(desc.aux, frameDebugView(desc.debugView, desc.settings))
            : id == kShadow     ? drawing && fx.shadowLayers > 0
            : id == kAo         ? drawing && fx.ao.variant != scene::AoVariant::Off
            : id == kThickness  ? drawing && fx.thickness
            : id == kReflection ? drawing && fx.reflection
                                : drawing;
        if (!needed)
            release(targets[id]);
        else if (!ensureTarget(id, error))
            return false;
    }
    return true;
}

void SceneRenderer::Impl::fillFrameData(const FrameDesc& desc, const CameraSetup& cam, const FrameGather& g) {
    const bool sameCamera = haveHistory && historyCamera == desc.camera;
    SceneFrameData& fd = frameData;
    fd = {};
    GpuView& v = fd.view;
    v.viewMatrix = cam.view;
    v.projMatrix = cam.proj;
    v.viewProj = cam.viewProj;
    v.invViewProj = glm::inverse(cam.viewProj);
    v.prevViewProj = sameCamera ? prevViewProj : cam.viewProj;
    v.position = glm::vec4(cam.eye, 1.0f);
    v.forward = glm::vec4(-cam.zAxis, 0.0f);
    v.rayRight = glm::vec4(cam.xAxis / cam.proj[0][0], 0.0f);
    v.rayUp = glm::vec4(cam.yAxis / cam.proj[1][1], 0.0f);
    v.viewport = {float(desc.width), float(desc.height), 1.0f / float(desc.width), 1.0f / float(desc.height)};
    v.jitter = glm::vec4(g.jitter, sameCamera ? lastJitter : g.jitter);
    v.frameIndex = frameIndex;
    fd.scene.ambient = glm::vec4(desc.settings.ambient, desc.settings.exposure);
    fd.scene.background = glm::vec4(desc.settings.background, 1.0f);
    fd.scene.params = {uint32_t(g.lights.size()), uint32_t(desc.settings.shading),
                       uint32_t(desc.settings.toneMapper), g.hardwareSrgb || g.post ? 1u : 0u};
    fd.scene.ambientSky = glm::vec4(desc.settings.ambientSky.value_or(desc.settings.ambient), 0.0f);
    const EffectsDesc& fx = g.effects;
    fd.scene.effects = {fx.shadowLayers, fx.ao.variant != scene::AoVariant::Off ? 1u : 0u,
                        fx.thickness ? 1u : 0u, fx.reflection ? 1u : 0u};
    for (const ecs::Material* m : g.materials) {
        const uint32_t flags =
            (m->reflections && m->roughness <= fx.reflections.roughnessCutoff ? kMaterialReflections : 0u) |
            (m->normalTexture != 0 ? kMaterialNormalTexture : 0u);
        fd.materials.push_back(
            {m->baseColor,
             glm::vec4(m->emissive, m->metallic),
             {m->roughness, m->baseColorTexture != 0 ? 1.0f : 0.0f, m->triplanarScale, float(flags)},
             glm::vec4(m->subsurfaceColor * m->subsurface, m->subsurfaceRadius)});
    }
    for (const LightSource& l : g.lights) {
        const reference::LightSample& ls = l.sample;
        const float type = ls.type == ecs::LightType::Directional ? 0.0f
                           : ls.type == ecs::LightType::Point     ? 1.0f
                                                                  : 2.0f;
        fd.lights.push_back({glm::vec4(ls.position, type), glm::vec4(ls.direction, ls.range),
                             glm::vec4(ls.radiance, ls.radius),
                             glm::vec4(float(l.shadowLayer), l.angularRadius, 0, 0)});
    }
    if (fd.lights.empty()) fd.lights.push_back(GpuLight{});  // bindable; params.x = 0 lights
    for (size_t i = 0; i < g.sources.size(); ++i) {
        GpuObject o;
        o.model = g.sources[i].model;
        auto prev = prevModels.find(g.sources[i].entity);
        o.prevModel = prev != prevModels.end() ? prev->second : o.model;
        const glm::mat3 m3(o.model);
        const glm::mat3 nm =
            std::abs(glm::determinant(m3)) > 1e-30f ? glm::inverseTranspose(m3) : glm::mat3(1.0f);
        o.normalMatrix = glm::mat4(nm);
        o.info = {g.drawMaterial[i], g.sources[i].entity.index, 0u, 0u};
        fd.objects.push_back(o);
    }
    fillSdfData(g);
}

// The SDF objects and the records of every shape program they use (each program once).
void SceneRenderer::Impl::fillSdfData(const FrameGather& g) {
    SdfSceneData& sd = sdfData;
    sd = {};
    std::unordered_map<const sdf::ShapeProgram*, uint32_t> firstRecord;
    bool hasField = false;
    auto bound = [](double v) { return float(std::clamp(v, -double(kSdfUnbounded), double(kSdfUnbounded))); };
    for (const SdfSource& s : g.sdfs) {
        GpuSdfObject o{};
        o.model = s.model;
        o.worldToLocal = glm::inverse(s.model);
        auto prev = prevModels.find(s.entity);
        o.prevModel = prev != prevModels.end() ? prev->second : s.model;
        glm::dvec3 lo, hi;
        if (s.program) {
            auto [it, added] = firstRecord.emplace(s.program, uint32_t(sd.records.size()));
            if (added)
                sd.records.insert(sd.records.end(), s.program->records.begin(), s.program->records.end());
            o.info = {uint32_t(SdfKind::Shapes), it->second, s.material, s.entity.index};
            lo = s.program->bounds.min;
            hi = s.program->bounds.max;
        } else {
            // The solid lies within the source mesh bounds; one voxel more covers hits found
            // within the hit epsilon just outside the surface.
            const sdf::PsdfHeader& h = s.field->header;
            o.info = {uint32_t(SdfKind::Field), atlas.slotOf(s.renderer->sdf), s.material, s.entity.index};
            lo = h.boundsMin - h.voxelSize;
            hi = h.boundsMax + h.voxelSize;
        }
        // A relative margin keeps rays that graze a box edge (float rounding) inside it. An axis
        // with an infinite side (a half-space such as a plane) gets an infinite margin, so its
        // finite side is unbounded too: the trace accepts hits up to its hit epsilon in front of a
        // surface, which for a plane seen far away lies well above a tight box top (a finite top
        // lost the far floor's horizon pixels).
        const glm::dvec3 margins = 1e-4 * glm::max(glm::abs(lo), glm::abs(hi)) + 1e-6;
        for (int a = 0; a < 3; ++a) {
            const double margin = margins[a];
            o.boundsMin[a] = bound(std::isfinite(lo[a]) ? lo[a] - margin : -HUGE_VAL);
            o.boundsMax[a] = bound(std::isfinite(hi[a]) ? hi[a] + margin : HUGE_VAL);
        }
        o.boundsMin.w = s.sigma;
        o.params = {s.renderer->maxSteps, s.renderer->castShadows ? kSdfObjectCastsShadows : 0u, 0u, 0u};
        sd.objects.push_back(o);
        hasField = hasField || s.field;
    }
    sd.tracedCount = g.tracedSdfs;
    if (hasField) {
        sd.fields = atlas.fields().data();
        sd.fieldBytes = atlas.fields().size() * sizeof(GpuSdfField);
        sd.atlas = atlas.texture();
    }
}

// Each mesh's buffers and each texture imported once; one MeshDraw per source.
std::vector<MeshDraw> SceneRenderer::Impl::importDraws(const FrameGather& g) {
    std::unordered_map<const GpuMesh*, std::pair<fg::BufferRef, fg::BufferRef>> meshRefs;
    std::vector<MeshDraw> draws;
    draws.reserve(g.sources.size());
    for (size_t i = 0; i < g.sources.size(); ++i) {
        const GpuMesh* gm = g.gpuMeshes[i];
        auto it = meshRefs.find(gm);
        if (it == meshRefs.end()) {
            const std::string base = fmt::format("mesh.{:016x}", g.sources[i].renderer->mesh);
            it =
                meshRefs
                    .emplace(
                        gm, std::make_pair(
                                graph.importBuffer(base + ".vertices", gm->vertices, rhi::Access::VertexRead),
                                graph.importBuffer(base + ".indices", gm->indices, rhi::Access::IndexRead)))
                    .first;
        }
        MeshDraw d;
        d.vertices = it->second.first;
        d.indices = it->second.second;
        d.indexCount = gm->indexCount;
        d.objectIndex = uint32_t(i);
        if (g.albedo)
            d.baseColor = importMaterialTexture(g.materialTexture[g.drawMaterial[i]],
                                                g.materials[g.drawMaterial[i]]->baseColorTexture);
        draws.push_back(d);
    }
    return draws;
}

// A material texture (or the white one, id 0) imported once per frame.
fg::TextureRef SceneRenderer::Impl::importMaterialTexture(rhi::TextureHandle tex, assets::AssetId id) {
    auto t = textureRefs.find(tex.value);
    if (t == textureRefs.end()) {
        const std::string name = id != 0 ? fmt::format("texture.{:016x}", id) : std::string("texture.white");
        t = textureRefs.emplace(tex.value, graph.importTexture(name, tex, rhi::Access::ShaderSampled)).first;
    }
    return t->second;
}

// The normal maps of the traced SDF objects' materials (meshes do not read normal maps yet); a
// normal texture that is not loaded is an error, as a base-colour one is.
bool SceneRenderer::Impl::uploadSdfNormalMaps(const assets::AssetManager& assets, FrameGather& g,
                                              std::string& error) {
    g.materialNormal.assign(g.materials.size(), rhi::TextureHandle{});
    for (uint32_t i = 0; i < g.tracedSdfs; ++i) {
        const uint32_t m = g.sdfs[i].material;
        const assets::AssetId id = g.materials[m]->normalTexture;
        if (id == 0 || g.materialNormal[m]) continue;
        const assets::TextureData* data = assets.texture(id);
        if (!data) {
            error = fmt::format("{} (SdfRenderer): normal texture {:016x} is not loaded",
                                entityName(g.sdfs[i].entity), id);
            return false;
        }
        const GpuTexture* t = cache.texture(id, *data, error);
        if (!t) return false;
        g.materialNormal[m] = t->texture;
    }
    return true;
}

// The materials of traced SDF objects that have a base-colour texture or a normal map, each once,
// with their textures imported (sdf_surface's input).
std::vector<SdfSurfaceMaterial> SceneRenderer::Impl::sdfSurfaceMaterials(const FrameGather& g) {
    std::vector<SdfSurfaceMaterial> out;
    std::vector<bool> seen(g.materials.size(), false);
    for (uint32_t i = 0; i < g.tracedSdfs; ++i) {
        const uint32_t m = g.sdfs[i].material;
        if (seen[m]) continue;
        seen[m] = true;
        SdfSurfaceMaterial sm;
        sm.material = m;
        const assets::AssetId base = g.materials[m]->baseColorTexture;
        if (base != 0 && g.albedo) sm.baseColor = importMaterialTexture(g.materialTexture[m], base);
        if (g.materialNormal[m])
            sm.normal = importMaterialTexture(g.materialNormal[m], g.materials[m]->normalTexture);
        if (sm.baseColor.isValid() || sm.normal.isValid()) out.push_back(sm);
    }
    return out;
}

// Imports the persistent targets, publishes them and orders the feature modules. Returns the bytes
// of the transient targets.
uint64_t SceneRenderer::Impl::buildGraph(const FrameDesc& desc, const CameraSetup& cam,
                                         const FrameGather& g) {
    graph.reset();
    board.clear();
    textureRefs.clear();
    FrameContext fc{device, graph, gpuCache, board, desc.width, desc.height};
    Output& out = board.add<Output>();
    out.srgbTarget = g.hardwareSrgb;
    out.color = g.external
                    ? graph.importTexture("output", desc.target, desc.targetAccess, desc.targetFinalAccess)
                    : graph.importPersistent("output", targets[kOutput].handle, rhi::Access::CopySrc);
    if (g.sources.empty() && g.tracedSdfs == 0) {
        const glm::vec3 bg = desc.settings.background * desc.settings.exposure;
        std::array<float, 4> encoded{};
        // An sRGB target encodes on write (clears included): give it the linear value.
        for (int c = 0; c < 3; ++c) {
            const float mapped = reference::toneMap(desc.settings.toneMapper, bg[c]);
            encoded[size_t(c)] = g.hardwareSrgb ? mapped : reference::srgbEncode(mapped);
        }
        encoded[3] = 1.0f;
        addBackground(fc, encoded);
        return 0;
    }
    addSceneUpload(fc, frameData);
    auto importTarget = [&](TargetId id) {
        return graph.importPersistent(kTargets[id].name, targets[id].handle, rhi::Access::ShaderSampled);
    };
    const DebugView view = frameDebugView(desc.debugView, desc.settings);  // none: lit
    GBuffer& gb = board.add<GBuffer>();
    gb = {importTarget(kDepth),
          importTarget(kNormal),
          importTarget(kMaterial),
          importTarget(kVelocity),
          g.albedo ? importTarget(kAlbedo) : fg::TextureRef{},
          frameNeedsAux(desc.aux, view) ? importTarget(kAux) : fg::TextureRef{}};
    uint64_t transientBytes = 0;
    // The trace mode (renderer/features/sdf_box_trace.h): `auto` by the object count and the boxes'
    // screen coverage. The box trace tests against the mesh pass's depth, which it then keeps.
    lastBoxTrace = {};
    lastTraceMode = scene::TraceMode::Fullscreen;
    lastTraceObjectsUniform = false;
    const std::span<const GpuSdfObject> traced = std::span(sdfData.objects).first(sdfData.tracedCount);
    lastBoxCoverage =
        g.tracedSdfs > 0 ? boxCoverage(traced, cam.view, cam.proj, cam.nearPlane, cam.farPlane) : 0.0;
    if (g.tracedSdfs > 0)
        lastTraceMode = resolveTraceMode(desc.settings.traceMode, g.tracedSdfs, lastBoxCoverage);
    const bool boxTrace = lastTraceMode == scene::TraceMode::Box;
    if (!g.sources.empty()) transientBytes = addMeshGBuffer(fc, importDraws(g), boxTrace);
    if (!g.sdfs.empty()) {
        addSdfSceneUpload(fc, sdfData, sdfStore);
        addWorldCache(fc, desc, cam);
        SdfTraceDesc trace;
        trace.settings = desc.settings.resolvedTrace();
        trace.raster = !g.sources.empty();
        trace.nearPlane = cam.nearPlane;
        trace.farPlane = cam.farPlane;
        trace.footprint = 2.0f / (float(desc.height) * std::abs(cam.proj[1][1]));
        trace.accel = desc.settings.acceleration;
        trace.countEvaluations = desc.auxEvaluations;
        // Per-tile lists of the traced objects (the tiles debug view shows them whatever the toggle).
        if (g.tracedSdfs > 0 &&
            ((desc.settings.acceleration.culling && !boxTrace) || view == DebugView::Tiles))
            addSdfTileCull(fc, {std::span(sdfData.objects).first(sdfData.tracedCount), cam.view,
                                cam.unjitteredProj, cam.nearPlane, cam.farPlane});
        if (g.tracedSdfs > 0 && boxTrace) {
            SdfBoxTraceDesc box;
            box.settings = trace.settings;
            box.raster = trace.raster;
            box.nearPlane = trace.nearPlane;
            box.farPlane = trace.farPlane;
            box.footprint = trace.footprint;
            box.countEvaluations = trace.countEvaluations;
            box.objects = traced;
            box.view = cam.view;
            box.proj = cam.unjitteredProj;  // the near-plane test and the coverage estimate
            lastBoxTrace = addSdfBoxTrace(fc, box);
        } else if (g.tracedSdfs > 0) {
            lastTraceObjectsUniform = addSdfTrace(fc, trace);  // occluders only: the effects still see them
        }
        // Textured SDF materials: triplanar base colour and normal maps in object space.
        if (g.tracedSdfs > 0) addSdfSurface(fc, sdfSurfaceMaterials(g));
        if (g.effects.any()) {
            const EffectsDesc& fx = g.effects;
            Effects& e = board.add<Effects>();
            e.shadowLayers = fx.shadowLayers;
            if (fx.shadowLayers > 0) e.shadow = importTarget(kShadow);
            if (fx.ao.variant != scene::AoVariant::Off) e.ao = importTarget(kAo);
            if (fx.thickness) e.thickness = importTarget(kThickness);
            if (fx.reflection) e.reflection = importTarget(kReflection);
            EffectsDesc run = fx;
            run.nearPlane = trace.nearPlane;
            run.farPlane = trace.farPlane;
            run.footprint = trace.footprint;
            addEffects(fc, run);
        }
    }
    if (view != DebugView::None) {
        const scene::TraceSettings trace = desc.settings.resolvedTrace();
        addDebugView(fc, {view, debugDepthRange(cam, g), trace.maxSteps, desc.settings.slice,
                          trace.fieldSafety, cam.nearPlane, cam.farPlane});
    } else if (!g.post) {
        addLighting(fc);
    } else {
        // TAA / motion blur: lighting writes the linear colour, post_output the output.
        const Output display = out;
        out.color = importTarget(kSceneColor);
        out.srgbTarget = false;
        out.format = kTargets[kSceneColor].format;
        addLighting(fc);
        const fg::TextureRef color = g.taa ? taa.add(fc, out.color) : out.color;
        out = display;
        addPostOutput(fc, color, desc.settings.motionBlur, g.taa);
    }
    return transientBytes;
}

// The world SDF cache (renderer/features/sdf_world_cache.h) when the world cache or the id field
// is on and the frame has SDF objects; otherwise its textures are freed.
void SceneRenderer::Impl::addWorldCache(FrameContext& fc, const FrameDesc& desc, const CameraSetup& cam) {
    const scene::AccelerationSettings& accel = desc.settings.acceleration;
    std::string why;
    if (!(accel.worldCache || accel.idField) || sdfData.objects.empty())
        worldCache.release(graph);
    else if (!worldCache.add(fc, sdfData, cam.eye, accel, why))
        log::warn("scene renderer: {} (the frame runs without the world cache)", why);
    // The SDF passes bind the cache in every frame: stand-ins when it did not run.
    if (!sdfData.objects.empty() && !board.has<SdfWorldCacheView>()) worldCache.addStandIn(fc);
}

// The depth debug view spans the camera to the farthest drawn bounding sphere (meshes, bounded SDF
// objects), at most the far plane.
float SceneRenderer::Impl::debugDepthRange(const CameraSetup& cam, const FrameGather& g) const {
    float farthest = 0.0f;
    auto sphere = [&](const glm::mat4& m, glm::vec3 center, float radius) {
        const float scale = std::max(
            {glm::length(glm::vec3(m[0])), glm::length(glm::vec3(m[1])), glm::length(glm::vec3(m[2]))});
        const glm::vec3 c = glm::vec3(m * glm::vec4(center, 1.0f));
        farthest = std::max(farthest, glm::dot(c - cam.eye, -cam.zAxis) + scale * radius);
    };
    for (size_t i = 0; i < g.sources.size(); ++i)
        sphere(g.sources[i].model, glm::vec3(0.0f), g.gpuMeshes[i]->radius);
    for (uint32_t i = 0; i < sdfData.tracedCount; ++i) {  // occluders are drawn as meshes
        const GpuSdfObject& o = sdfData.objects[i];
        const glm::vec3 lo(o.boundsMin), hi(o.boundsMax);
        if (glm::max(glm::abs(lo), glm::abs(hi)).x >= kSdfUnbounded * 0.5f ||
            std::max({std::abs(lo.y), std::abs(hi.y), std::abs(lo.z), std::abs(hi.z)}) >=
                kSdfUnbounded * 0.5f)
            continue;  // unbounded (planes): no finite sphere
        sphere(o.model, 0.5f * (lo + hi), 0.5f * glm::length(hi - lo));
    }
    return std::clamp(farthest > 0.0f ? farthest : cam.farPlane, 1e-6f, cam.farPlane);
}

// History for the next frame's velocity, timings and statistics.
void SceneRenderer::Impl::finishFrame(const FrameDesc& desc, const CameraSetup& cam, const FrameGather& g,
                                      uint64_t transientBytes) {
    haveFrame = true;
    lastOwnOutput = !g.external;
    lastGbuffer = !g.sources.empty() || g.tracedSdfs > 0;
    lastAlbedo = lastGbuffer && g.albedo;
    lastAux = lastGbuffer && frameNeedsAux(desc.aux, frameDebugView(desc.debugView, desc.settings));
    const bool fxRan = lastGbuffer && !g.sdfs.empty();
    lastEffect[kShadow] = fxRan && g.effects.shadowLayers > 0;
    lastEffect[kAo] = fxRan && g.effects.ao.variant != scene::AoVariant::Off;
    lastEffect[kThickness] = fxRan && g.effects.thickness;
    lastEffect[kReflection] = fxRan && g.effects.reflection;
    haveHistory = true;
    historyCamera = desc.camera;
    prevViewProj = cam.viewProj;
    lastJitter = g.jitter;
    if (g.taa) taa.endFrame();
    prevModels.clear();
    for (const DrawSource& src : g.sources) prevModels[src.entity] = src.model;
    for (const SdfSource& src : g.sdfs) prevModels[src.entity] = src.model;
    ++frameIndex;

    FrameStats& st = stats;
    st = {};
    // Timings arrive a few frames late; they are collected here without waiting (takeTimings and
    // lastFrameStats hand them out).
    for (fg::FrameTimings& t : graph.pollTimings()) completedTimings.push_back(std::move(t));
    uint64_t triangles = 0;
    for (const GpuMesh* m : g.gpuMeshes) triangles += m->indexCount / 3;
    st.memory.meshBuffers = cache.meshBytes();
    st.memory.textures = cache.textureBytes();
    st.memory.sceneBuffers = board.has<SceneBuffers>() ? board.find<SceneBuffers>()->bytes : 0;
    st.effects = effectsReport(g);
    st.memory.renderTargets = targetBytes() + transientBytes + st.effects.lowResBytes + taa.bytes();
    st.drawCalls = uint32_t(g.sources.size());
    st.sdfObjects = g.tracedSdfs;
    st.sdfOccluders = uint32_t(g.sdfs.size()) - g.tracedSdfs;
    st.memory.sdfAtlas = atlas.bytes();
    st.atlas = {atlas.bytes(),
                atlas.fill(),
                atlas.residentCount(),
                atlas.size().x,
                atlas.size().y,
                atlas.size().z,
                atlas.texture() ? rhi::formatInfo(atlas.format()).name : "none"};
    if (board.has<SdfSceneBuffers>()) st.memory.sceneBuffers += board.find<SdfSceneBuffers>()->bytes;
    if (g.sdfs.empty()) worldCache.release(graph);
    if (board.has<SdfWorldCacheView>()) {
        st.worldCache = worldCache.report();
        st.memory.worldCache = board.find<SdfWorldCacheView>()->bytes;
    }
    if (!g.sdfs.empty()) {
        const SdfSceneStore::Stats& up = sdfStore.stats();
        st.sdfUpload = {up.objectsUploaded, up.fullUpload, up.deltaBytes, up.uploadBytes,
                        up.objectBufferBytes};
    }
    keptBuffers.clear();
    // The SDF object array (GpuSdfObject per object, traced first) for readBuffer: the box-trace
    // tests check written depth against each object's bounds box.
    if (const SdfSceneBuffers* sb = board.find<SdfSceneBuffers>(); sb && !sdfData.objects.empty())
        keptBuffers["sdf.objects"] = {graph.physicalBuffer(sb->objects),
                                      uint64_t(sdfData.objects.size()) * sizeof(GpuSdfObject)};
    if (const SdfCullLists* lists = board.find<SdfCullLists>()) {
        for (const SdfTileLists* l : {&lists->primary, &lists->shadow, &lists->ao}) {
            st.tileListBytes += l->bytes;
            st.tileListScratchBytes += l->scratchBytes;
        }
        if (lists->primary.valid()) {
            const uint64_t rangeBytes = uint64_t(lists->primary.tilesX) * lists->primary.tilesY * 8;
            keptBuffers["sdf.tile_ranges"] = {graph.physicalBuffer(lists->primary.ranges), rangeBytes};
            keptBuffers["sdf.tile_indices"] = {graph.physicalBuffer(lists->primary.indices),
                                               lists->primary.bytes - rangeBytes};
            if (lists->primary.dispatch.isValid())
                keptBuffers["sdf.tile_dispatch"] = {
                    graph.physicalBuffer(lists->primary.dispatch),
                    (kSdfTileDispatchHeader +
                     uint64_t(kSdfTileClasses) * lists->primary.tilesX * lists->primary.tilesY) *
                        4};
        }
    }
    st.triangles = triangles;
    st.traceMode = lastTraceMode;
    st.traceObjectsUniform = lastTraceObjectsUniform;
    st.boxDraws = lastBoxTrace.boxes;
    st.nearDraws = lastBoxTrace.nearDraws;
    st.boxCoverage = lastBoxCoverage;
    st.lights = uint32_t(g.lights.size());
    st.materials = uint32_t(g.materials.size());
    // The shadow / AO tile lists and their counters for readBuffer (features/sdf_effects_cull.h).
    if (const SdfEffectsCullCounters* fx = board.find<SdfEffectsCullCounters>()) {
        const SdfCullLists& l = *board.find<SdfCullLists>();
        auto keep = [&](const char* name, fg::BufferRef ref, uint64_t bytes) {
            keptBuffers[name] = {graph.physicalBuffer(ref), bytes};
        };
        keep("sdf.effects_cull_counters", fx->buffer, 16);
        keep("sdf.effects_tile_indices", fx->indices, fx->indexBytes);
        const SdfTileLists& any = l.shadow.valid() ? l.shadow : l.ao;
        const uint64_t tiles = uint64_t(any.tilesX) * any.tilesY;
        if (l.shadow.valid()) keep("sdf.shadow_tile_ranges", l.shadow.ranges, tiles * l.shadow.layers * 8);
        if (l.ao.valid()) keep("sdf.ao_tile_ranges", l.ao.ranges, tiles * 8);
    }
}

std::vector<fg::FrameTimings> SceneRenderer::takeTimings(bool wait) {
    Impl& s = *m_impl;
    for (fg::FrameTimings& t : wait ? s.graph.flushTimings() : s.graph.pollTimings())
        s.completedTimings.push_back(std::move(t));
    for (const fg::FrameTimings& t : s.completedTimings)
        if (t.frame == s.lastFrameNumber) {
            s.stats.passes = t.passes;
            s.statsFrameNumber = t.frame;
        }
    return std::exchange(s.completedTimings, {});
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
    if (!s.device.readTexture(t.handle, {}, s.graph.persistentState(t.handle), texels) ||
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
    for (uint32_t id = 0; id < kOutput; ++id) {
        if (name != kTargets[id].name) continue;
        const bool effect = id == kShadow || id == kAo || id == kThickness || id == kReflection;
        const bool present = s.haveFrame && s.lastGbuffer && (id != kAlbedo || s.lastAlbedo) &&
                             (id != kAux || s.lastAux) && (!effect || s.lastEffect[id]);
        if (!present) {
            error = "scene renderer: readTarget: '" + name + "' was not part of the last frame";
            return false;
        }
        const Target& t = s.targets[id];
        if (!s.device.readTexture(t.handle, {}, s.graph.persistentState(t.handle), texels)) {
            error = "scene renderer: readTarget: reading back '" + name + "' failed";
            return false;
        }
        format = kTargets[id].format;
        return true;
    }
    error =
        "scene renderer: readTarget: unknown target '" + name +
        "' (gbuffer.depth, gbuffer.normal, gbuffer.material, gbuffer.velocity, gbuffer.albedo, gbuffer.aux, "
        "effects.shadow, effects.ao, effects.thickness, effects.reflection)";
    return false;
}

bool SceneRenderer::readWorldCache(WorldCacheReadback& out, std::string& error) {
    Impl& s = *m_impl;
    if (!s.haveFrame || !s.stats.worldCache.active) {
        error = "scene renderer: readWorldCache: the last frame had no world cache";
        return false;
    }
    return s.worldCache.readBack(s.graph, out, error);
}

bool SceneRenderer::readBuffer(const std::string& name, std::vector<uint8_t>& bytes, std::string& error) {
    Impl& s = *m_impl;
    const auto it = s.keptBuffers.find(name);
    if (it == s.keptBuffers.end() || !it->second.first) {
        error = "scene renderer: readBuffer: '" + name + "' was not kept by the last frame";
        return false;
    }
    bytes.resize(it->second.second);
    if (!s.device.readBuffer(it->second.first, 0, bytes.size(), bytes.data())) {
        error = "scene renderer: readBuffer: reading back '" + name + "' failed";
        return false;
    }
    return true;
}

const FrameStats& SceneRenderer::lastFrameStats() const {
    Impl& s = *m_impl;
    if (s.haveFrame && s.statsFrameNumber != s.lastFrameNumber) {
        // The last frame's timings, waiting for them if needed (never called inside a frame loop
        // that must not block: such loops use takeTimings(false)). Frames nobody took yet stay
        // queued for takeTimings().
        for (fg::FrameTimings& t : s.graph.flushTimings()) s.completedTimings.push_back(std::move(t));
        for (const fg::FrameTimings& t : s.completedTimings)
            if (t.frame == s.lastFrameNumber) s.stats.passes = t.passes;
        s.statsFrameNumber = s.lastFrameNumber;
    }
    return s.stats;
}

std::string SceneRenderer::lastFrameGraphviz() const { return m_impl->graphviz; }

void SceneRenderer::collectAssets(const assets::AssetManager& assets) { m_impl->cache.collect(assets); }

}  // namespace penumbra::render
