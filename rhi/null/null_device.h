// Null backend: records every command and executes none (no GPU). Buffers and textures keep CPU
// copies so uploads, updateBuffer/copyBuffer/fillBuffer and readback round-trip; shaders never run.
// Timestamps are the CPU clock at submission, so they increase. Used by unit tests (frame graph,
// validation) that need no GPU; the inspection functions below are for those tests.
#pragma once

#include <string>
#include <vector>

#include "rhi/device.h"

namespace rhi::null {

struct RecordedCommand {
    enum class Kind {
        Barrier,
        UpdateBuffer,
        CopyBuffer,
        FillBuffer,
        CopyTexture,
        CopyBufferToTexture,
        BindPipeline,
        BindGroup,
        PushConstants,
        Dispatch,
        DispatchIndirect,
        BeginRenderPass,
        EndRenderPass,
        SetViewport,
        SetScissor,
        BindVertexBuffer,
        BindIndexBuffer,
        Draw,
        DrawIndexed,
        DrawIndirect,
        DrawIndexedIndirect,
        ResetQueries,
        WriteTimestamp,
        PushDebugGroup,
        PopDebugGroup,
    };
    Kind kind;
    std::vector<rhi::Barrier> barriers;      // Kind::Barrier
    std::string label;                       // PushDebugGroup name, BeginRenderPass debugName
    PipelineHandle pipeline;                 // BindPipeline
    BindGroupHandle group;                   // BindGroup
    uint32_t set = 0;                        // BindGroup
    std::vector<TextureHandle> attachments;  // BeginRenderPass: colour targets then depth (if any)
    uint32_t counts[3] = {0, 0, 0};          // Dispatch groups / Draw vertex,instance / query index
};

// Commands of every list submitted to `device` so far, in submission order. `device` must be a
// null device or the validation wrapper around one; otherwise returns an empty list.
const std::vector<RecordedCommand>& recordedCommands(const rhi::Device& device);
void clearRecordedCommands(rhi::Device& device);
// Number of objects of all kinds still alive (not destroyed) and pending deferred destruction.
size_t liveObjectCount(const rhi::Device& device);

}  // namespace rhi::null
