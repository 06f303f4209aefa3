// penumbra RHI — the device: resource creation, submission, readback and presentation.
// Create one with rhi::createDevice(). Every method says what it maps to on each backend.
//
// Lifetime rules
// - Creation functions return an invalid handle on failure and log one clear message.
// - destroy() invalidates the handle at once (any later use is a stale handle, which the
//   validation wrapper reports); the GPU object itself is released only after every submission
//   recorded before the destroy() has completed on the GPU (deferred destruction).
// - Readback functions block until the GPU is idle; they are meant for tests, screenshots and
//   tools, not for per-frame use.
#pragma once

#include <memory>

#include "rhi/command_list.h"
#include "rhi/types.h"

namespace rhi {

class Device {
public:
    virtual ~Device() = default;

    virtual const DeviceInfo& info() const = 0;

    // --- creation ------------------------------------------------------------------------------
    // VK: vkCreateBuffer + sub-allocated vkAllocateMemory   GL: glCreateBuffers + glNamedBufferStorage
    // initialData (optional, desc.size bytes) is uploaded before the handle is returned.
    virtual BufferHandle createBuffer(const BufferDesc& desc, const void* initialData = nullptr) = 0;
    // VK: vkCreateImage + vkCreateImageView   GL: glCreateTextures + glTextureStorage{2D,3D}
    virtual TextureHandle createTexture(const TextureDesc& desc) = 0;
    // VK: vkCreateSampler   GL: glCreateSamplers + glSamplerParameteri
    virtual SamplerHandle createSampler(const SamplerDesc& desc) = 0;
    // VK: vkCreateShaderModule (desc.spirv)   GL: glCreateShader + glCompileShader (desc.glsl)
    virtual ShaderHandle createShader(const ShaderDesc& desc) = 0;
    // VK: vkCreateDescriptorSetLayout x sets + vkCreatePipelineLayout + vkCreateComputePipelines
    // GL: glCreateProgram + glLinkProgram
    virtual PipelineHandle createComputePipeline(const ComputePipelineDesc& desc) = 0;
    // VK: as above + vkCreateGraphicsPipelines (dynamic rendering, dynamic viewport/scissor)
    // GL: glLinkProgram + a VAO describing the vertex layout + a fixed-function state block
    virtual PipelineHandle createGraphicsPipeline(const GraphicsPipelineDesc& desc) = 0;
    // VK: vkAllocateDescriptorSets + vkUpdateDescriptorSets   GL: a recorded list of bindings
    virtual BindGroupHandle createBindGroup(const BindGroupDesc& desc) = 0;
    // VK: vkCreateQueryPool(VK_QUERY_TYPE_TIMESTAMP)   GL: glGenQueries
    virtual QueryPoolHandle createQueryPool(const QueryPoolDesc& desc) = 0;

    // --- destruction (deferred until the GPU is done with it) ------------------------------------
    // VK: vkDestroy* once the last submission that may use it has signalled its fence
    // GL: glDelete* once the fence sync of the last such submission has signalled
    virtual void destroy(BufferHandle h) = 0;
    virtual void destroy(TextureHandle h) = 0;
    virtual void destroy(SamplerHandle h) = 0;
    virtual void destroy(ShaderHandle h) = 0;
    virtual void destroy(PipelineHandle h) = 0;
    virtual void destroy(BindGroupHandle h) = 0;
    virtual void destroy(QueryPoolHandle h) = 0;

    // Whether the handle refers to a live object of this device (stale/foreign handles: false).
    virtual bool isAlive(BufferHandle h) const = 0;
    virtual bool isAlive(TextureHandle h) const = 0;
    virtual bool isAlive(SamplerHandle h) const = 0;
    virtual bool isAlive(ShaderHandle h) const = 0;
    virtual bool isAlive(PipelineHandle h) const = 0;
    virtual bool isAlive(BindGroupHandle h) const = 0;
    virtual bool isAlive(QueryPoolHandle h) const = 0;

    // Descriptions as created (for validation, tools and the frame graph). Null for dead handles.
    virtual const BufferDesc* describe(BufferHandle h) const = 0;
    virtual const TextureDesc* describe(TextureHandle h) const = 0;

    // --- uploads (ordered before any later submission) -------------------------------------------
    // VK: memcpy into a staging buffer + vkCmdCopyBuffer on the upload command buffer, which is
    //     submitted ahead of the next submit()   GL: glNamedBufferSubData
    virtual void writeBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) = 0;
    // Tightly packed texels for one subresource (Tex3D: the whole mip volume). Expects the texture
    // in the state its last recorded barrier left it in (Access::None when new) and leaves it in
    // Access::ShaderSampled (a frame graph imports uploaded textures in that state).
    // VK: staging + layout transitions + vkCmdCopyBufferToImage   GL: glTextureSubImage{2D,3D}
    virtual void writeTexture(TextureHandle dst, TextureSubresource sub, const void* data, uint64_t size) = 0;
    // Tightly packed texels (rows of region.width, then slices) of a box inside one subresource;
    // the texels outside it keep their contents. States as writeTexture.
    // VK: staging + vkCmdCopyBufferToImage (imageOffset)   GL: glTextureSubImage{2D,3D} (offset)
    virtual void writeTextureRegion(TextureHandle dst, const TextureRegion& region, const void* data,
                                    uint64_t size) = 0;
    // Persistently mapped pointer of a MemoryType::Upload / Readback buffer, else nullptr.
    // VK: vkMapMemory (once)   GL: glMapNamedBufferRange(MAP_PERSISTENT | MAP_COHERENT)
    virtual void* mappedPointer(BufferHandle h) = 0;

    // --- submission ------------------------------------------------------------------------------
    // VK: a command buffer from a per-submission pool, vkBeginCommandBuffer
    // GL: a recorder whose commands are replayed on the context at submit()
    virtual CommandList& beginCommandList(std::string_view debugName = {}) = 0;
    // Returns a monotonically increasing submission serial.
    // VK: vkEndCommandBuffer + vkQueueSubmit2 with a timeline-semaphore signal   GL: replay + glFenceSync
    virtual uint64_t submit(CommandList& list) = 0;
    // VK: vkWaitSemaphores (timeline)   GL: glClientWaitSync
    virtual void waitForSubmission(uint64_t serial) = 0;
    // VK: vkDeviceWaitIdle   GL: glFinish. Also releases every deferred destruction.
    virtual void waitIdle() = 0;
    // Releases resources whose deferred destruction is due; called by submit() as well.
    virtual void collectGarbage() = 0;

    // --- readback (blocking) ---------------------------------------------------------------------
    // VK: vkCmdCopyBuffer into a readback buffer + wait   GL: glGetNamedBufferSubData
    virtual bool readBuffer(BufferHandle src, uint64_t offset, uint64_t size, void* out) = 0;
    // Tightly packed texels of one subresource (Tex3D: whole mip volume), rows top to bottom.
    // The texture must be in `currentAccess` (the state the last barrier left it in); it is
    // returned to that state afterwards.
    // VK: layout transition + vkCmdCopyImageToBuffer + wait   GL: glGetTextureSubImage
    virtual bool readTexture(TextureHandle src, TextureSubresource sub, Access currentAccess,
                             std::vector<uint8_t>& out) = 0;
    // Timestamps in nanoseconds (period already applied), waits for them to be available.
    // Counted in stats().blockingTimestampReads.
    // VK: vkGetQueryPoolResults(WAIT | 64_BIT)   GL: glGetQueryObjectui64v(GL_QUERY_RESULT)
    virtual bool readTimestamps(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs) = 0;
    // Non-blocking: if every query of the range has a result (its command list was submitted and
    // has executed past it), writes them as readTimestamps does and returns true; otherwise returns
    // false at once and leaves outNs untouched (misuse such as a bad range is also logged).
    // VK: vkGetQueryPoolResults(64_BIT | WITH_AVAILABILITY) without WAIT
    // GL: glGetQueryObjectui64v(GL_QUERY_RESULT_AVAILABLE), then GL_QUERY_RESULT
    virtual bool tryReadTimestamps(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs) = 0;

    // --- capabilities ----------------------------------------------------------------------------
    // What the device supports for `format` (textures: optimal tiling).
    // VK: vkGetPhysicalDeviceFormatProperties   GL: glGetInternalformativ (+ the GL image-unit rules)
    virtual FormatSupport formatSupport(Format format) const = 0;

    // --- statistics ------------------------------------------------------------------------------
    // Counters since creation (VK and GL: kept by the backend; the validation wrapper forwards).
    virtual DeviceStats stats() const = 0;

    // --- presentation (windowed devices only) ------------------------------------------------------
    // Returns the texture to render into this frame (ColorTarget-capable, format backbufferFormat()).
    // VK: vkAcquireNextImageKHR   GL: an offscreen texture owned by the device
    virtual TextureHandle acquireBackbuffer() = 0;
    virtual Format backbufferFormat() const = 0;
    // The backbuffer must have been transitioned to Access::Present by the caller.
    // VK: vkQueuePresentKHR   GL: glBlitNamedFramebuffer (flipped to the window) + glfwSwapBuffers
    virtual bool present() = 0;
    // VK: swapchain re-creation   GL: backbuffer re-creation
    virtual void resizeBackbuffer(uint32_t width, uint32_t height) = 0;
};

// Creates a device. Returns null (after logging why through desc.log) if the backend cannot be
// created. Backend::Auto tries Vulkan, then OpenGL. PENUMBRA_BACKEND overrides Auto.
// With desc.validation the device is wrapped in the validation layer (rhi/validation).
std::unique_ptr<Device> createDevice(const DeviceDesc& desc);

// Number of misuse reports the validation wrapper (and, when enabled, the Vulkan validation layer
// or GL debug output at error severity) has sent to the log since the device was created.
// Always 0 for devices created without validation.
uint64_t validationErrorCount(const Device& device);

}  // namespace rhi
