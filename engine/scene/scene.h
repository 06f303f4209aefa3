// Scenes: a World plus the render settings and asset references that came with it. Loaded from the
// JSON scene format (docs/FORMATS.md, "Scene JSON") or directly from a glTF file.
//
//   assets::AssetManager assets;
//   scene::Scene scene;
//   std::string error;
//   if (!scene::loadScene("scenes/default.json", assets, scene, error)) { report(error); }
//   ...
//   scene::unloadScene(scene, assets);  // releases the scene's asset references
//
// Loading is atomic: on failure the output Scene and the asset manager are unchanged (every asset
// reference taken during the attempt is released) and `error` holds one message naming the file,
// the element (a JSON pointer such as "/entities/3/light/type") and the reason.
#pragma once

#include <cstdint>
#include <iterator>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/assets/gltf_scene.h"
#include "engine/ecs/world.h"

namespace penumbra::scene {

enum class ShadingModel : uint8_t { CookTorrance, BlinnPhong };
enum class ToneMapper : uint8_t { Clamp, Reinhard, Aces };

const char* shadingModelName(ShadingModel m);  // "cook-torrance", "blinn-phong"
const char* toneMapperName(ToneMapper t);      // "clamp", "reinhard", "aces"
bool parseShadingModel(std::string_view s, ShadingModel& out);
bool parseToneMapper(std::string_view s, ToneMapper& out);

// What a frame shows instead of the lit image (`penumbra render --debug-view`, the render block's
// "debugView"; renderer/features/debug_view.h describes each view).
enum class DebugView : uint32_t {
    None,
    Normals,
    Depth,
    Albedo,
    Steps,
    Ids,
    FieldSlice,
    Ao,
    Shadow,
    BentNormal,
    Thickness,
    Tiles  // the primary tile lists' lengths (renderer/features/sdf_cull.h)
};
inline constexpr const char* kDebugViewNames[] = {"none",   "normals",    "depth",       "albedo",
                                                  "steps",  "ids",        "field-slice", "ao",
                                                  "shadow", "bentnormal", "thickness",   "tiles"};
inline const char* toString(DebugView view) {
    return kDebugViewNames[uint32_t(view) < std::size(kDebugViewNames) ? uint32_t(view) : 0];
}
inline bool parseDebugView(std::string_view text, DebugView& out) {
    for (uint32_t i = 0; i < std::size(kDebugViewNames); ++i)
        if (text == kDebugViewNames[i]) {
            out = DebugView(i);
            return true;
        }
    return false;
}

// The "render" object of a scene file.
// Sphere-tracing settings of the SDF trace (renderer/features/sdf_trace.h explains each one).
// Epsilons are in pixel footprints: the size of one pixel at the distance of the point.
enum class TraceQuality : uint8_t { Low, Medium, High, Reference };
const char* toString(TraceQuality q);  // "low", "medium", "high", "reference"
bool parseTraceQuality(std::string_view text, TraceQuality& out);

struct TraceSettings {
    uint32_t maxSteps = 128;      // step limit per ray (an object's own maxSteps may raise it)
    uint32_t refineSteps = 16;    // hit decision: evaluations per object searched for its root (0: none)
    float hitEpsilon = 0.5f;      // hit when the distance is below this many pixel footprints
    float normalEpsilon = 0.5f;   // gradient step for normals, pixel footprints
    float overRelaxation = 1.3f;  // Keinert's omega (1 = plain sphere tracing), in [1, 2)
    float fieldSafety = 1.0f;     // times the trilinear interpolation bound subtracted from fields
};
// The preset of a quality level (docs/FORMATS.md lists the values).
TraceSettings tracePreset(TraceQuality quality);

// Settings a scene's render block sets one by one over the preset.
struct TraceOverrides {
    std::optional<uint32_t> maxSteps, refineSteps;
    std::optional<float> hitEpsilon, normalEpsilon, overRelaxation, fieldSafety;
};

// ---- effects (renderer/features/effects.h) ----------------------------------------------------
// Soft shadows, cone traced through the scene's SDFs for every light with castShadows.
struct ShadowSettings {
    bool enabled = true;           // false: no shadow pass (lights are unshadowed)
    bool hard = false;             // binary visibility (the light's size is ignored)
    float resolutionScale = 0.5f;  // of the frame's width and height, in (0, 1]
    uint32_t maxSteps = 0;         // cone-trace step limit; 0: from the trace quality (docs/FORMATS.md)
};

// Ambient occlusion variants (renderer/features/sdf_ao.h).
enum class AoVariant : uint8_t {
    Off,
    FiveTap,   // 5 distance taps along the normal (Evans, Quilez)
    MultiRay,  // 5 taps along each of several Fibonacci directions (mTec); "reference" quality: exact
               // binary visibility along many rays
    Cones      // 9 cones with a bent normal (Wright)
};
inline constexpr const char* kAoVariantNames[] = {"off", "five-tap", "multi-ray", "cones"};
inline const char* toString(AoVariant v) {
    return kAoVariantNames[uint32_t(v) < std::size(kAoVariantNames) ? uint32_t(v) : 0];
}
inline bool parseAoVariant(std::string_view text, AoVariant& out) {
    for (uint32_t i = 0; i < std::size(kAoVariantNames); ++i)
        if (text == kAoVariantNames[i]) {
            out = AoVariant(i);
            return true;
        }
    return false;
}

struct AoSettings {
    AoVariant variant = AoVariant::Off;
    float maxDistance = 1.0f;       // occluders farther than this (scene units) do not occlude
    float strength = 1.0f;          // ao = 1 - strength * occlusion
    float resolutionScale = 0.25f;  // of the frame's width and height, in (0, 1]
    uint32_t rays = 0;              // multi-ray directions; 0: from the trace quality
};

// One traced reflection bounce for materials with "reflections": true.
struct ReflectionSettings {
    float roughnessCutoff = 0.5f;  // rougher materials get no traced reflection
    uint32_t maxSteps = 0;         // 0: from the trace quality
};

// How rasterized meshes take part in the SDF passes (`--mesh-sdf`, the render block's "meshSdf").
enum class MeshSdfMode : uint8_t {
    Off,        // meshes are only rasterized: they receive SDF shadows and AO but cast none
    Trace,      // every visible mesh becomes an SdfRenderer of its baked field (comparisons)
    Occlusion,  // meshes stay rasterized and get a baked field used only for shadows and AO
    Auto        // Occlusion when the frame has effects (shadowed lights or AO) and meshes, else Off
};

// How the SDF objects reach the G-buffer (issue 14; `--trace-mode`, the render block's "traceMode";
// renderer/features/sdf_box_trace.h).
enum class TraceMode : uint8_t {
    Fullscreen,  // one compute invocation per pixel traces every object (sdf_trace)
    Box,         // each object's bounds box is rasterized and traced in its own field (sdf_box_trace)
    Auto         // Box or Fullscreen by the measured crossover (object count, screen coverage)
};
bool parseTraceMode(std::string_view text, TraceMode& out);
const char* toString(TraceMode mode);

// ---- acceleration (issue 13: renderer/features/sdf_cull.h, sdf_world_cache.h) -------------------
// Each toggle only changes speed: the picture matches the unaccelerated render within the parity
// rule (tests). `render.acceleration` in the scene JSON, `--accel` on the CLI (docs/FORMATS.md).
struct AccelerationSettings {
    bool culling = true;                // 8x8 pixel tile lists of objects for the trace, shadows and AO
    bool worldCache = false;            // clipmapped world distance: long safe steps far from surfaces
    bool idField = false;               // object-id field: near a surface evaluate the one object it names
    bool prepass = false;               // coarse-to-fine cone prepass per 8x8 tile (optional)
    uint32_t cacheLevels = 4;           // clipmap levels (each twice the voxel size of the last)
    uint32_t cacheResolution = 64;      // voxels per side of each level (multiple of 8)
    float cacheVoxel = 0.0f;            // level-0 voxel size in world units; 0: from the scene's size
    uint32_t cacheBudgetVoxels = 2048;  // dirty-region voxels recomputed per frame (rest queued)
};

// Motion blur from the velocity buffer (renderer/features/motion_blur.h): each pixel gathers
// `samples` taps along its tile's largest motion, scaled by `strength` (1 = the motion of one frame
// interval, i.e. a shutter open for the whole frame).
struct MotionBlurSettings {
    bool enabled = false;
    float strength = 1.0f;  // 0..4
    uint32_t samples = 8;   // 2..32 taps per pixel
};

struct RenderSettings {
    uint32_t width = 640;
    uint32_t height = 360;
    ShadingModel shading = ShadingModel::CookTorrance;
    ToneMapper toneMapper = ToneMapper::Aces;
    float exposure = 1.0f;                        // multiplies linear radiance before tone mapping
    glm::vec3 ambient{0.03f};                     // ambient radiance (linear RGB); from below with a sky
    std::optional<glm::vec3> ambientSky;          // ambient from straight up (hemisphere ambient: the
                                                  // lighting blends by the normal's y); unset: constant
    glm::vec3 background{0.0f};                   // linear RGB where nothing is hit
    std::string camera;                           // camera entity name; empty = the first camera
    double fixedDt = 1.0 / 60.0;                  // update step of the app loop (seconds)
    TraceQuality quality = TraceQuality::Medium;  // the trace preset (--quality replaces it)
    TraceOverrides trace;                         // the scene's per-setting overrides
    DebugView debugView = DebugView::None;        // --debug-view replaces it
    glm::vec4 slice{0.0f, 1.0f, 0.0f, 0.0f};      // field-slice plane dot(xyz, p) = w, xyz unit
    ShadowSettings shadows;
    AoSettings ao;
    ReflectionSettings reflections;
    MeshSdfMode meshSdf = MeshSdfMode::Auto;  // --mesh-sdf replaces it
    AccelerationSettings acceleration;        // --accel replaces the toggles
    // How SDF objects are traced (render.traceMode); --trace-mode replaces it.
    TraceMode traceMode = TraceMode::Fullscreen;
    bool taa = false;               // temporal anti-aliasing (render.taa; --taa replaces it)
    MotionBlurSettings motionBlur;  // render.motionBlur; --motion-blur replaces `enabled`
    // The preset of `quality` with the overrides applied.
    TraceSettings resolvedTrace() const;
};

// Spins an entity about a local axis (scene animation for the app loop and velocity tests).
struct Spin {
    glm::vec3 axis{0.0f, 1.0f, 0.0f};  // unit
    float radiansPerSecond = 0.0f;
};
// Advances every Spin by dt (rotation = angleAxis(rate * dt, axis) * rotation).
void spinSystem(ecs::World& world, double dt);

struct Scene {
    ecs::World world;
    RenderSettings settings;
    std::string sourcePath;
    std::vector<assets::AssetId> assetRefs;  // references this scene holds (one per use)
};

struct SceneLoadLimits {
    uint64_t maxFileBytes = 64ull << 20;  // scene JSON file size cap
    int maxJsonDepth = 64;
    size_t maxEntities = 1u << 20;
    size_t maxMaterials = 1u << 16;
    assets::GltfSceneLimits gltf;
};

// By extension: .json -> JSON scene, .gltf / .glb -> glTF scene (default render settings).
bool loadScene(const std::string& path, assets::AssetManager& assets, Scene& out, std::string& error,
               const SceneLoadLimits& limits = {});
bool loadJsonScene(const std::string& path, assets::AssetManager& assets, Scene& out, std::string& error,
                   const SceneLoadLimits& limits = {});
// Parses scene JSON text; relative asset paths resolve against `baseDir`; messages name `name`.
bool parseJsonScene(std::string_view text, const std::string& name, const std::string& baseDir,
                    assets::AssetManager& assets, Scene& out, std::string& error,
                    const SceneLoadLimits& limits = {});

// Releases every asset reference of the scene and clears it.
void unloadScene(Scene& scene, assets::AssetManager& assets);

// The camera named `name` (Camera::name or the entity's Name), or the first camera in entity order
// when `name` is empty. Null entity when there is none.
ecs::Entity findCamera(const ecs::World& world, std::string_view name);

// The current scene-format version written in "version" (docs/FORMATS.md); files of every version
// from kMinSceneFormatVersion on load (version 2 added the `sdf` component).
inline constexpr int kSceneFormatVersion = 2;
inline constexpr int kMinSceneFormatVersion = 1;

}  // namespace penumbra::scene
