// Feature "sdf_effects_cull": the shadow and AO tile lists (SdfCullLists::shadow and ::ao of
// renderer/features/sdf_cull.h), after mTec 8.2.6 (shadow culling) and 8.2.8 (AO culling). The passes
// "sdf_tile_cull_effects_tiles" (each tile's surface sphere) and "sdf_tile_cull_effects"
// (renderer/shaders/sdf_tile_cull_effects.comp describes the tests) run after the G-buffer is
// complete and before sdf_shadow / sdf_ao: per 8x8 tile of the full-resolution
// frame, the casting objects whose bounding sphere meets the region a shadow ray of the tile can
// cross (one list per shadowed light, layer = GpuLight::shadow.x) or that lie within reach of the
// tile's AO rays. Conservative: an object any effect ray of the tile can see is in the list; the
// passes then narrow it per ray or pixel as before (sdf_cone.glsl sdfConeCull, sdf_ao.comp).
//
// Storage without a fixed per-tile cap: each list reserves its exact length with an atomic counter.
// The indices buffer holds sdfEffectsListCapacity entries: every tile x list x object when that is
// at most kSdfEffectsMeanList objects (the exact worst case: small scenes never run out), else a
// mean of kSdfEffectsMeanList entries per list. The CPU cannot bound these lists tightly (a shadow
// list depends on the depth buffer and on lights that reach across the screen), so the bound is a
// memory budget that grows with the frame and the light count; a list reserved past it is written
// as "all objects" (count 0xffffffff) and its pixels take the unculled path (correct, slower).
#pragma once

#include <cstdint>

#include "renderer/core/shader_params.h"
#include "renderer/features/effects.h"
#include "renderer/features/sdf_cull.h"
#include "renderer/features/sdf_world_cache.h"

namespace penumbra::render {

inline constexpr uint32_t kSdfEffectsMeanList = 32;

// Entries of the indices buffer for `tiles` tiles, `lists` lists per tile and `objects` objects.
uint64_t sdfEffectsListCapacity(uint64_t tiles, uint32_t lists, uint32_t objects);

// The pass's counters (4 x uint32, kept to the end of the frame for SceneRenderer::readBuffer
// "sdf.effects_cull_counters"): slots reserved, lists over capacity, sum of list lengths, lists of
// tiles with a surface (mean list length = [2] / [3]). The buffer holds a fifth, internal slot: the
// frame's largest field voxel (float bits) from sdf_tile_cull_effects_tiles for the lists pass.
struct SdfEffectsCullCounters {
    fg::BufferRef buffer;
    fg::BufferRef indices;    // the shadow and AO lists' shared indices ("sdf.effects_tile_indices")
    uint64_t indexBytes = 0;  // its size (capacity x 4)
};

// Adds the passes (a transfer clear of the counters, then the two compute passes) and publishes
// SdfCullLists::shadow (desc.shadowLayers > 0) and ::ao (AO on), keeping ::primary, and
// SdfEffectsCullCounters. Reads
// SceneBuffers (view, scene constants, lights), SdfSceneBuffers and GBuffer::depth.
void addSdfEffectsCull(FrameContext& fc, const EffectsDesc& desc);

// The acceleration flags of sdf_shadow / sdf_ao (their push constants): 1 the tile lists are
// bound, 2 no culling at all (every casting object at every step), 4 world-cache steps, 8 the id
// field (4 and 8 only when the cache ran this frame: `cacheBound`).
uint32_t sdfEffectsAccelFlags(const scene::AccelerationSettings& accel, const SdfTileLists& lists,
                              bool cacheBound);

}  // namespace penumbra::render
