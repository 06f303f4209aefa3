// Feature "mesh_gbuffer": the raster pass "gbuffer_mesh" that draws every visible MeshRenderer
// into the deferred G-buffer (renderer/scene_renderer.h documents the layout): linear depth,
// octahedral normal, packed material (16-bit index, SDF object 0), velocity in pixels and, when
// some material of the frame has a base-colour texture, albedo (shader variant ALBEDO).
// Depth-tested against a transient D32 depth buffer. Reads SceneBuffers and writes the GBuffer
// published on the blackboard.
#pragma once

#include <cstdint>
#include <vector>

#include "renderer/features/frame_context.h"

namespace penumbra::render {

// One draw: an uploaded mesh (buffers imported into the graph) and its object slot.
struct MeshDraw {
    fg::BufferRef vertices;
    fg::BufferRef indices;
    uint32_t indexCount = 0;
    uint32_t objectIndex = 0;  // into the objects buffer
    fg::TextureRef baseColor;  // albedo variant: the material's texture (or white); else invalid
};

// The pass's hardware depth buffer (D32, the projection's depth of the nearest mesh, cleared to 1),
// published on the blackboard when keepDepth is set: the box trace (sdf_box_trace.h) tests against
// it and writes it, so meshes and box-traced SDF objects occlude each other.
struct MeshDepth {
    fg::TextureRef depth;
};

// Adds the pass (clears and writes every GBuffer target). Returns the bytes of its transient
// depth buffer. keepDepth: store the depth buffer and publish it (MeshDepth) for a later raster pass.
uint64_t addMeshGBuffer(FrameContext& fc, std::vector<MeshDraw> draws, bool keepDepth = false);

}  // namespace penumbra::render
