// Feature "sdf_world_cache": the clipmapped world SDF + object-id field (issue 13 items 1 and 2,
// after mTec 8.2.2 and Wright's global SDF clipmaps; renderer/features/world_cache_clipmap.h holds
// the layout, the values, their margins and the update rule, renderer/shaders/sdf_world_cache.glsl
// the lookup the trace and the effects use).
//
// Persistent R32F distance and R32UI id textures (R x R x R L, levels stacked in z), created here
// and imported into each frame's graph (importPersistent); recreated when the layout changes. Per
// frame: the transfer pass "sdf_world_cache_upload" writes the levels table, the jobs and their
// object lists planned by WorldCacheClipmap; the compute passes "sdf_world_cache_splat" (the
// immediate min-splats of changed objects, one invocation per voxel of their concatenated boxes)
// and then "sdf_world_cache" (scrolled-in slabs, whole levels, queued dirty bricks within the
// budget, one workgroup per job). The view is published
// as SdfWorldCacheView; passes that use it are ordered after the update by the graph.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "engine/scene/scene.h"
#include "renderer/core/shader_params.h"
#include "renderer/features/frame_context.h"
#include "renderer/features/sdf_scene.h"
#include "renderer/features/world_cache_clipmap.h"

namespace penumbra::render {

// Published on the blackboard when the cache ran this frame (absent when it is off or the frame
// has no SDF objects).
struct SdfWorldCacheView {
    fg::TextureRef distance;  // R32F 3D, R x R x (R levelCount)
    fg::TextureRef ids;       // R32UI 3D, same size
    fg::BufferRef levels;     // uvec4 (count, R, 0, 0) + CacheLevelGpu[levelCount]
    uint32_t levelCount = 0;
    uint64_t bytes = 0;          // both textures + the levels buffer
    rhi::SamplerHandle sampler;  // nearest (texelFetch only; GL needs it for integer textures)
};

// Published instead of SdfWorldCacheView when the cache did not run this frame: a 1x1x1 distance
// and id texture and a levels buffer with a level count of 0, persistent (made once per renderer,
// so a frame without the cache adds no pass for them). The SDF passes declare the cache's bindings
// in every frame and bind these, never sampling them (their cache flags are off).
struct SdfWorldCacheStandIn {
    SdfWorldCacheView view;
};

// The cache a pass binds: this frame's SdfWorldCacheView (`bound` true) or the stand-ins.
SdfWorldCacheView sdfWorldCacheBinding(const Blackboard& board, bool& bound);

// Declares the cache as a shader input (textures sampled, levels read).
void readSdfWorldCache(fg::PassBuilder& b, const SdfWorldCacheView& view);
// Binds sdfCacheDistance, sdfCacheIds (nearest sampler; the lookup uses texelFetch) and
// SdfCacheLevels (renderer/shaders/sdf_world_cache.glsl).
void setSdfWorldCache(ShaderParams& params, const fg::PassContext& ctx, const SdfWorldCacheView& view);

class SdfWorldCache {
public:
    explicit SdfWorldCache(rhi::Device& device) : m_device(device) {}
    ~SdfWorldCache();
    SdfWorldCache(const SdfWorldCache&) = delete;
    SdfWorldCache& operator=(const SdfWorldCache&) = delete;

    // Plans and adds this frame's update passes; publishes SdfWorldCacheView. Call after
    // addSdfSceneUpload (reads SdfSceneBuffers). `scene` must stay alive until the graph ran.
    // False with `error` when the textures cannot be created (the frame goes on without a cache).
    bool add(FrameContext& fc, const SdfSceneData& scene, glm::vec3 camera,
             const scene::AccelerationSettings& settings, std::string& error);
    // The cache is off or the frame has no SDF objects: frees the textures.
    void release(fg::FrameGraph& graph);
    // Publishes SdfWorldCacheStandIn for a frame without the cache (creates the stand-ins once).
    void addStandIn(FrameContext& fc);

    const WorldCacheReport& report() const { return m_report; }
    const WorldCacheClipmap& clipmap() const { return m_clipmap; }
    // Reads the whole cache back (tests); false when it did not run in the last frame.
    bool readBack(const fg::FrameGraph& graph, WorldCacheReadback& out, std::string& error) const;

private:
    bool ensureTextures(fg::FrameGraph& graph, std::string& error);
    void destroyTextures(fg::FrameGraph& graph);

    rhi::Device& m_device;
    WorldCacheClipmap m_clipmap;
    rhi::TextureHandle m_distance, m_ids;
    rhi::TextureHandle m_standInDistance, m_standInIds;
    rhi::BufferHandle m_standInLevels;
    uint32_t m_texLevels = 0, m_texResolution = 0;
    std::vector<ClipmapObject> m_objects;
    std::vector<uint8_t> m_levelsData;  // header + levels, read by the upload pass
    std::vector<uint32_t> m_flags;      // per object: 1 = exact shape program (ids may name it)
    WorldCacheReport m_report;
};

}  // namespace penumbra::render
