// What every feature module gets to add its passes to a frame, and the blackboard entries the
// modules of the scene renderer publish and read (renderer/scene_renderer.cpp orders them):
//
//   module          reads                          publishes
//   scene_upload    SceneFrameData (CPU)           SceneBuffers
//   mesh_gbuffer    SceneBuffers, GBuffer, draws   (writes the GBuffer targets)
//   sdf_scene       SdfSceneData (CPU)             SdfSceneBuffers
//   sdf_cull        SceneBuffers, SdfSceneBuffers  SdfCullLists::primary (per-tile object lists)
//   sdf_world_cache SdfSceneBuffers, objects (CPU) SdfWorldCacheView (persistent textures)
//   sdf_trace       SceneBuffers, SdfSceneBuffers, (reads the mesh pass's depth, writes the GBuffer)
//                   GBuffer
//   sdf_surface     SceneBuffers, SdfSceneBuffers, (writes GBuffer albedo / normal of textured
//                   GBuffer, material textures      SDF materials)
//   effects         SceneBuffers, SdfSceneBuffers, Effects, EffectsLowRes (renderer/features/
//                   GBuffer                          effects.h; writes the Effects targets)
//   lighting        SceneBuffers, GBuffer, Effects  (writes Output)
//                   (when published), Output
//   debug_view      SceneBuffers, GBuffer (aux for  (writes Output instead of lighting)
//                   ids / steps), Output
//   debug_field_    SceneBuffers, SdfSceneBuffers  (writes Output instead of lighting; adds an
//     slice         (added empty if absent), Output empty sdf_upload when no SDF is drawn)
//
// GBuffer and Output are the renderer's persistent targets, imported into the graph by the frame
// function and published before the modules run.
#pragma once

#include <cstdint>

#include "renderer/core/blackboard.h"
#include "renderer/core/gpu_cache.h"
#include "renderer/frame_graph/frame_graph.h"
#include "rhi/device.h"

namespace penumbra::render {

struct FrameContext {
    rhi::Device& device;
    fg::FrameGraph& graph;
    GpuCache& cache;
    Blackboard& board;
    uint32_t width = 0;
    uint32_t height = 0;
};

// This frame's scene buffers (frame-graph transients written by scene_upload).
struct SceneBuffers {
    fg::BufferRef view;       // GpuView, uniform (set 0)
    fg::BufferRef scene;      // GpuScene, uniform (set 1, binding 0)
    fg::BufferRef objects;    // GpuObject[], storage
    fg::BufferRef materials;  // GpuMaterial[], storage
    fg::BufferRef lights;     // GpuLight[] (>= 1 element), storage
    uint64_t bytes = 0;       // sum of their sizes
};

// The G-buffer of one frame (renderer/scene_renderer.h documents the layout); albedo is invalid
// when no material of the frame has a base-colour texture, aux when the frame did not ask for it.
struct GBuffer {
    fg::TextureRef depth;     // R32_FLOAT linear view depth
    fg::TextureRef normal;    // RG16_FLOAT octahedral world normal
    fg::TextureRef material;  // RGBA8_UNORM material index (16 bit) / SDF object index + 1 (16 bit)
    fg::TextureRef velocity;  // RG16_FLOAT pixels
    fg::TextureRef albedo;    // RGBA8_UNORM sRGB-encoded (gbuffer.glsl packAlbedo), optional
    fg::TextureRef aux;       // RG32_FLOAT entity index / trace steps, optional (AOVs, debug views)
};

// The frame's colour output (RGBA8_UNORM with the sRGB OETF applied in the shader, or RGBA8_SRGB
// encoded by the hardware).
struct Output {
    fg::TextureRef color;
    bool srgbTarget = false;
    // RGBA16_FLOAT: the linear scene colour lighting writes for TAA / motion blur (post_output.h)
    // instead of the RGBA8 output; Undefined: RGBA8 (srgbTarget says which).
    rhi::Format format = rhi::Format::Undefined;
};

}  // namespace penumbra::render
