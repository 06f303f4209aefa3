// penumbra RHI — command recording. A CommandList is obtained from Device::beginCommandList(),
// recorded on one thread, and handed back with Device::submit(). Commands execute in recording
// order on the single graphics+compute queue. Each method says what it maps to per backend.
#pragma once

#include "rhi/types.h"

namespace rhi {

class CommandList {
public:
    virtual ~CommandList() = default;

    // --- synchronisation -------------------------------------------------------------------
    // VK: vkCmdPipelineBarrier2 (image layouts derived from the accesses)
    // GL: pending bits folded into one glMemoryBarrier before the next use
    virtual void barrier(std::span<const Barrier> barriers) = 0;
    void barrier(const Barrier& b) { barrier(std::span<const Barrier>(&b, 1)); }

    // --- transfers ---------------------------------------------------------------------------
    // VK: vkCmdUpdateBuffer (size <= 65536, multiple of 4)   GL: glNamedBufferSubData
    virtual void updateBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) = 0;
    // VK: vkCmdCopyBuffer   GL: glCopyNamedBufferSubData
    virtual void copyBuffer(BufferHandle src, uint64_t srcOffset, BufferHandle dst, uint64_t dstOffset,
                            uint64_t size) = 0;
    // VK: vkCmdFillBuffer   GL: glClearNamedBufferSubData (R32UI)
    virtual void fillBuffer(BufferHandle dst, uint64_t offset, uint64_t size, uint32_t value) = 0;
    // Copies the box srcRegion of src to dstRegion's mip, layer and offset in dst (dstRegion's
    // extent: zero or equal to the source box). Same format; the source subresource in CopySrc,
    // the destination one in CopyDst (they may be two mips or layers of one texture).
    // VK: vkCmdCopyImage   GL: glCopyImageSubData
    virtual void copyTexture(TextureHandle src, const TextureRegion& srcRegion, TextureHandle dst,
                             const TextureRegion& dstRegion) = 0;
    // Tightly packed texels (rows of the region width, then slices) from src at srcOffset (a
    // multiple of the texel size) into a box of one subresource. src in CopySrc, dst in CopyDst.
    // VK: vkCmdCopyBufferToImage   GL: glTextureSubImage{2D,3D} from GL_PIXEL_UNPACK_BUFFER
    virtual void copyBufferToTexture(BufferHandle src, uint64_t srcOffset, TextureHandle dst,
                                     const TextureRegion& dstRegion) = 0;

    // --- compute -----------------------------------------------------------------------------
    // VK: vkCmdBindPipeline   GL: glUseProgram (+ fixed-function state for graphics pipelines)
    virtual void bindPipeline(PipelineHandle pipeline) = 0;
    // VK: vkCmdBindDescriptorSets   GL: glBindBufferRange / glBindTextureUnit + glBindSampler /
    //     glBindImageTexture at the flattened bindings
    virtual void bindGroup(uint32_t set, BindGroupHandle group) = 0;
    // VK: vkCmdPushConstants   GL: glNamedBufferSubData into the reserved UBO (kGlPushConstantBinding)
    virtual void pushConstants(const void* data, uint32_t size, uint32_t offset = 0) = 0;
    // VK: vkCmdDispatch   GL: glDispatchCompute
    virtual void dispatch(uint32_t groupsX, uint32_t groupsY = 1, uint32_t groupsZ = 1) = 0;
    // VK: vkCmdDispatchIndirect   GL: glDispatchComputeIndirect
    virtual void dispatchIndirect(BufferHandle args, uint64_t offset) = 0;

    // --- graphics ----------------------------------------------------------------------------
    // VK: vkCmdBeginRendering (dynamic rendering)   GL: glBindFramebuffer (cached FBO) + glClear*
    virtual void beginRenderPass(const RenderPassDesc& desc) = 0;
    // VK: vkCmdEndRendering   GL: glInvalidateNamedFramebufferData for DontCare stores
    virtual void endRenderPass() = 0;
    // VK: vkCmdSetViewport   GL: glViewportIndexedf + glDepthRangeIndexed
    virtual void setViewport(const Viewport& vp) = 0;
    // VK: vkCmdSetScissor   GL: glScissorIndexed (GL_SCISSOR_TEST always on)
    virtual void setScissor(const Rect& rect) = 0;
    // VK: vkCmdBindVertexBuffers   GL: glBindVertexBuffer on the pipeline's VAO
    virtual void bindVertexBuffer(uint32_t slot, BufferHandle buffer, uint64_t offset = 0) = 0;
    // VK: vkCmdBindIndexBuffer   GL: glVertexArrayElementBuffer
    virtual void bindIndexBuffer(BufferHandle buffer, IndexType type, uint64_t offset = 0) = 0;
    // VK: vkCmdDraw   GL: glDrawArraysInstancedBaseInstance
    virtual void draw(uint32_t vertexCount, uint32_t instanceCount = 1, uint32_t firstVertex = 0,
                      uint32_t firstInstance = 0) = 0;
    // VK: vkCmdDrawIndexed   GL: glDrawElementsInstancedBaseVertexBaseInstance
    virtual void drawIndexed(uint32_t indexCount, uint32_t instanceCount = 1, uint32_t firstIndex = 0,
                             int32_t vertexOffset = 0, uint32_t firstInstance = 0) = 0;
    // VK: vkCmdDrawIndirect   GL: glMultiDrawArraysIndirect
    virtual void drawIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) = 0;
    // drawCount indexed draws whose arguments (20-byte VkDrawIndexedIndirectCommand /
    // DrawElementsIndirectCommand records) start at `offset`; args in Access::IndirectRead, created
    // with BufferUsage::Indirect. The index buffer must be bound at offset 0 (GL has no base offset).
    // VK: vkCmdDrawIndexedIndirect   GL: glMultiDrawElementsIndirect
    virtual void drawIndexedIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) = 0;

    // --- queries and debugging -----------------------------------------------------------------
    // VK: vkCmdResetQueryPool   GL: no-op (query objects are overwritten)
    virtual void resetQueries(QueryPoolHandle pool, uint32_t first, uint32_t count) = 0;
    // VK: vkCmdWriteTimestamp2 (ALL_COMMANDS)   GL: glQueryCounter(GL_TIMESTAMP)
    virtual void writeTimestamp(QueryPoolHandle pool, uint32_t index) = 0;
    // VK: vkCmdBeginDebugUtilsLabelEXT   GL: glPushDebugGroup
    virtual void pushDebugGroup(std::string_view name) = 0;
    // VK: vkCmdEndDebugUtilsLabelEXT   GL: glPopDebugGroup
    virtual void popDebugGroup() = 0;
};

}  // namespace rhi
