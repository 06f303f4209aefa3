// The scene renderer: draws an ECS World through the frame graph, written once against the RHI.
// Its passes come from the feature modules in renderer/features/, in frame order:
//   scene_upload   (transfer)  per-frame camera, lights and materials; mesh vertex/index buffers
//                              and material textures are uploaded once per asset and kept
//   gbuffer_mesh   (raster)    MeshRenderer entities into the deferred G-buffer
//   sdf_upload     (transfer)  the frame's SDF objects and shape-program records
//   sdf_world_cache (compute)  clipmapped world distance + object-id field, scrolled and updated
//                              incrementally (renderer/features/sdf_world_cache.h; acceleration)
//   sdf_trace      (compute)   sphere tracing of the SdfRenderer entities into the same G-buffer,
//                              bounded by the mesh depth (hybrid)
//   sdf_box_trace  (raster)    instead of sdf_trace with render.traceMode box (or auto's choice):
//                              each object's bounds box rasterized and traced alone, depth-tested
//                              against the mesh pass's depth (renderer/features/sdf_box_trace.h)
//   sdf_surface    (compute)   textured SDF materials: triplanar albedo and normal maps in object
//                              space, one dispatch per material (renderer/features/sdf_surface.h)
//   effects        (compute)   sdf_shadow, sdf_ao, sdf_thickness, sdf_reflection, effects_upsample
//                              (renderer/features/effects.h: each only when the frame needs it)
//   lighting       (raster)    full-screen deferred lighting (Cook-Torrance or Blinn-Phong,
//                              directional, point and sphere lights with their shadows, hemisphere
//                              ambient x AO, translucency, reflections) + exposure + tone mapping,
//                              written sRGB-encoded into the RGBA8 output (with TAA or motion
//                              blur: linear into scene.color, RGBA16F)
//   taa            (raster)    render.taa: resolves scene.color with the jittered history
//                              (renderer/features/taa.h)
//   motion_blur_tiles (compute), post_output (raster)  with TAA or render.motionBlur: the colour into
//                              the output, sRGB-encoded, motion-blurred when asked
//                              (renderer/features/post_output.h)
//   debug_view     (raster)    instead of lighting when a debug view is set (FrameDesc::debugView,
//                              else the scene's render.debugView): one G-buffer channel (normals,
//                              depth, albedo, steps, ids) in the output, or debug_field_slice (the
//                              SDF scene's distance on a plane; renderer/features/debug_view.h)
// A pass is only added when the scene needs it (no MeshRenderer: no gbuffer_mesh pass; no
// SdfRenderer: no sdf_upload or sdf_trace pass; only occluderOnly SdfRenderers, the mesh fields of
// --mesh-sdf occlusion: sdf_upload for the effects but no sdf_trace).
//
// G-buffer (after mTec thesis 8.2.1, 96 bits per pixel, shared with the SDF passes of later issues):
//   gbuffer.depth     R32_FLOAT    linear view depth in scene units (0 = nothing hit)
//   gbuffer.normal    RG16_FLOAT   world normal, octahedral encoding in [-1, 1]^2
//   gbuffer.material  RGBA8_UNORM  r, g = 16-bit material index (low, high byte) / 255, so a frame
//                                  holds up to 65536 materials, the scene format's limit;
//                                  b, a = SDF object index + 1 (low, high byte) / 255, 0 for
//                                  meshes and the background (sdf_surface's object lookup; shadow
//                                  and AO have their own targets, renderer/features/effects.h);
//                                  objects from index 65535 on also store 0 (no object count
//                                  limit: sdf_surface leaves those untextured)
// mTec keeps an 8-bit id and an 8-bit SSS thickness in the r, g bytes; here the id takes both, and
// subsurface thickness has its own target (effects.thickness, renderer/features/effects.h).
// plus, outside the 96 bits (as in mTec: "other buffers"):
//   gbuffer.velocity  RG16_FLOAT   screen-space motion to the previous frame, in pixels
//   gbuffer.albedo    RGBA8_UNORM  base colour x texture, sRGB-encoded by the shaders (a UNORM target so
//                                  the compute trace can write it); only when a material has a
//                                  base-colour texture (otherwise lighting reads the material's factor)
//   gbuffer.aux       RG32_FLOAT   entity index (-1 background) and sphere-trace steps; only when
//                                  FrameDesc::aux asks for it (AOVs, debug views)
//   depth             D32_FLOAT    hardware depth for the raster passes
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/world.h"
#include "engine/image/image.h"
#include "engine/scene/scene.h"
#include "renderer/core/gbuffer_encoding.h"
#include "renderer/features/debug_view.h"
#include "renderer/features/world_cache_clipmap.h"
#include "renderer/frame_graph/frame_graph.h"
#include "rhi/device.h"

namespace penumbra::render {

// Device memory the renderer holds, by resource class (bytes).
struct MemoryReport {
    uint64_t meshBuffers = 0;    // vertex + index buffers of uploaded meshes
    uint64_t sceneBuffers = 0;   // camera / light / material / per-object buffers
    uint64_t textures = 0;       // material textures
    uint64_t renderTargets = 0;  // G-buffer, depth, output (frame graph transients included)
    uint64_t sdfAtlas = 0;       // the 3D field atlas (renderer/features/sdf_atlas.h)
    uint64_t worldCache = 0;     // world SDF cache textures + levels (renderer/features/sdf_world_cache.h)
    uint64_t total() const {
        return meshBuffers + sceneBuffers + textures + renderTargets + sdfAtlas + worldCache;
    }
};

// The field atlas after the frame (zeros when no field was ever drawn).
struct AtlasReport {
    uint64_t bytes = 0;
    double fill = 0.0;   // voxels of resident fields / texels of the atlas
    uint32_t slots = 0;  // resident fields (one per asset, however many instances)
    uint32_t width = 0, height = 0, depth = 0;
    const char* format = "none";
};

// The SDF effects of the frame (renderer/features/effects.h): which ran, and their targets' memory.
struct EffectsReport {
    uint32_t shadowLayers = 0;  // shadowed lights this frame = layers of effects.shadow (0: no sdf_shadow)
    const char* ao = "off";     // the AO variant that ran ("off": no sdf_ao, no effects.ao)
    bool thickness = false;     // sdf_thickness ran (effects.thickness)
    bool reflection = false;    // sdf_reflection ran (effects.reflection)
    uint64_t targetBytes = 0;   // the full-resolution effect targets (in MemoryReport::renderTargets)
    uint64_t lowResBytes = 0;   // the low-resolution shadow / AO transients (in renderTargets too)
};

// The SDF object upload of the frame (renderer/features/sdf_scene.h, SdfSceneStore): the object
// array is persistent and updated from deltas; zeros in a frame without SDF objects.
struct SdfUploadReport {
    uint32_t objectsUploaded = 0;    // GpuSdfObject records sent (changed ones, or all on a full rewrite)
    bool fullUpload = false;         // the whole array was rewritten (new buffer, > half changed)
    uint64_t deltaBytes = 0;         // the delta buffer scattered by sdf_object_scatter (0: none)
    uint64_t uploadBytes = 0;        // all bytes sent: objects + shape records + field table
    uint64_t objectBufferBytes = 0;  // the persistent object buffer (its capacity)
};

struct FrameStats {
    std::vector<fg::PassTiming> passes;  // executed passes in order
    MemoryReport memory;
    uint32_t drawCalls = 0;
    uint32_t sdfObjects = 0;    // SdfRenderer entities traced
    uint32_t sdfOccluders = 0;  // occluderOnly SdfRenderers (mesh fields seen by shadows and AO only)
    AtlasReport atlas;
    EffectsReport effects;
    SdfUploadReport sdfUpload;
    WorldCacheReport worldCache;  // the world SDF cache (inactive: off or no SDF objects)
    uint64_t triangles = 0;
    uint32_t lights = 0;
    uint32_t materials = 0;
    uint64_t tileListBytes = 0;         // per-tile object lists (renderer/features/sdf_cull.h), all kinds
    uint64_t tileListScratchBytes = 0;  // the culling passes' working buffers behind those lists
    // The trace mode that ran (scene::TraceMode Fullscreen or Box; `auto` resolved), and the
    // objects the box trace drew as boxes / as near-plane triangles (inside or crossing the near
    // plane, unbounded). Fullscreen when the frame traced no SDF object.
    scene::TraceMode traceMode = scene::TraceMode::Fullscreen;
    // The full-screen trace read the objects as a uniform block (its SDF_OBJECTS_UBO variants: at
    // most kSdfObjectsUniformCapacity objects, renderer/features/sdf_scene.h), else as storage.
    bool traceObjectsUniform = false;
    uint32_t boxDraws = 0;
    uint32_t nearDraws = 0;
    double boxCoverage = 0.0;  // the traced objects' boxes in screens (sdf_box_trace.h boxCoverage)
};

struct FrameDesc {
    uint32_t width = 0;
    uint32_t height = 0;
    ecs::Entity camera = ecs::kNullEntity;  // must have Camera + Transform
    scene::RenderSettings settings;
    // Optional external colour target (RGBA8_UNORM, or RGBA8_SRGB which encodes in hardware; e.g. a
    // window backbuffer) and the access state
    // it is in; the output is written there instead of the renderer's own texture and left in
    // `targetFinalAccess`.
    rhi::TextureHandle target;
    rhi::Access targetAccess = rhi::Access::None;
    rhi::Access targetFinalAccess = rhi::Access::ShaderSampled;
    // Show a G-buffer channel instead of the lit image; None: settings.debugView (the scene's).
    // Ids and steps make the frame write gbuffer.aux whatever `aux` says.
    DebugView debugView = DebugView::None;
    bool aux = false;  // also write gbuffer.aux (entity index, trace steps) for AOVs and debug views
    // gbuffer.aux y counts the trace's object distance evaluations instead of its steps (tests and
    // benchmarks of the acceleration: the work culling, world cache and id field save).
    bool auxEvaluations = false;
    // Restart the TAA history this frame (a camera cut): the frame is its own first sample.
    bool resetHistory = false;
};

class SceneRenderer {
public:
    explicit SceneRenderer(rhi::Device& device);
    ~SceneRenderer();
    SceneRenderer(const SceneRenderer&) = delete;
    SceneRenderer& operator=(const SceneRenderer&) = delete;

    // Renders one frame of `world` (transforms must be up to date: ecs::updateTransforms) and
    // submits it. False with `error` (e.g. no camera, a mesh asset missing, more than 255
    // materials, a device failure); the renderer stays usable.
    bool render(const ecs::World& world, const assets::AssetManager& assets, const FrameDesc& desc,
                std::string& error);

    // Reads back the last frame's output (own texture only) as 8-bit sRGB RGBA, row 0 = top.
    bool readPixels(ImageRGBA8& out, std::string& error);
    // Reads back a G-buffer target of the last frame by name ("gbuffer.depth", ...) as raw texels
    // (tests); false when the target was not part of the frame.
    bool readTarget(const std::string& name, std::vector<uint8_t>& texels, rhi::Format& format,
                    std::string& error);

    // Reads back the whole world SDF cache of the last frame (tests); false when it did not run.
    bool readWorldCache(WorldCacheReadback& out, std::string& error);

    // Reads back a buffer the last frame kept for tests: "sdf.tile_ranges", "sdf.tile_indices",
    // "sdf.tile_dispatch" (the primary tile lists and the trace's tile classes,
    // renderer/features/sdf_cull.h, when the frame built them), and with the
    // shadow / AO lists (renderer/features/sdf_effects_cull.h) "sdf.shadow_tile_ranges",
    // "sdf.ao_tile_ranges", "sdf.effects_tile_indices", "sdf.effects_cull_counters", and
    // "sdf.objects" (the frame's GpuSdfObject array, renderer/features/sdf_scene.h); false otherwise.
    bool readBuffer(const std::string& name, std::vector<uint8_t>& bytes, std::string& error);

    // The last frame's statistics; its pass timings are waited for if they have not arrived yet
    // (so frame loops that must not block use takeTimings(false) instead).
    const FrameStats& lastFrameStats() const;
    // Pass timings of every frame that arrived since the last call, oldest first: without waiting
    // (a few frames late), or with `wait` everything outstanding (the end of a run).
    std::vector<fg::FrameTimings> takeTimings(bool wait);
    std::string lastFrameGraphviz() const;

    // Drops every cached GPU copy of assets no longer alive in `assets` (call after unloading).
    void collectAssets(const assets::AssetManager& assets);

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
};

}  // namespace penumbra::render
