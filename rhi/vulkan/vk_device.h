// Vulkan backend — the device and its command lists (Vulkan 1.3: synchronization2, dynamic
// rendering, timeline semaphores). One graphics+compute queue; every submission signals one
// timeline semaphore with a monotonically increasing serial that keys deferred destruction and
// the recycling of command buffers and staging memory.
#pragma once

#include <vulkan/vulkan.h>

#include <array>
#include <deque>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "rhi/common/deferred_release.h"
#include "rhi/common/handle_pool.h"
#include "rhi/common/subresource_states.h"
#include "rhi/device.h"
#include "rhi/vulkan/vk_allocator.h"
#include "rhi/vulkan/vulkan_inspect.h"

namespace rhi::vk {

class VulkanDevice;

// --- resources ------------------------------------------------------------------------------------
struct BufferRes {
    VkBuffer buffer = VK_NULL_HANDLE;
    Allocation alloc;
    BufferDesc desc;
    VkBufferUsageFlags usage = 0;
};

struct TextureRes {
    VkImage image = VK_NULL_HANDLE;
    Allocation alloc;
    TextureDesc desc;
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;
    VkImageUsageFlags usage = 0;
    VkImageView sampledView = VK_NULL_HANDLE;                   // every mip and layer
    std::vector<VkImageView> storageViews;                      // one per mip (all layers / whole volume)
    std::unordered_map<uint32_t, VkImageView> attachmentViews;  // key: mip << 16 | layer
    std::map<std::array<uint32_t, 4>, VkImageView> rangeViews;  // bind-group views of mip/layer ranges
    detail::SubresourceStates states;  // per mip and layer, as left by the last recorded barrier
    bool ownsImage = true;             // false for swapchain images (no memory, the swapchain owns them)
    bool backbuffer = false;           // handed out by acquireBackbuffer(): the device destroys it
};

struct SamplerRes {
    VkSampler sampler = VK_NULL_HANDLE;
};

struct ShaderRes {
    VkShaderModule module = VK_NULL_HANDLE;
    ShaderStage stage = ShaderStage::Compute;
    struct Binding {
        std::string name;
        uint32_t set = 0;
        uint32_t binding = 0;
        BindingType type = BindingType::UniformBuffer;
        uint32_t count = 1;
        TextureDimension dimension = TextureDimension::Tex2D;
    };
    std::vector<Binding> bindings;
    std::vector<VertexInputReflection> vertexInputs;
    uint32_t pushConstantSize = 0;
    std::string name;
};

struct SetLayoutBinding {
    std::string name;
    uint32_t binding = 0;
    BindingType type = BindingType::UniformBuffer;
    uint32_t count = 1;
    VkShaderStageFlags stages = 0;
    TextureDimension dimension = TextureDimension::Tex2D;
};

struct PipelineRes {
    VkPipeline pipeline = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;  // owned
    VkPipelineBindPoint bindPoint = VK_PIPELINE_BIND_POINT_COMPUTE;
    std::array<VkDescriptorSetLayout, kMaxBindGroups> setLayouts{};  // cached by the device
    std::array<std::vector<SetLayoutBinding>, kMaxBindGroups> sets;
    uint32_t setCount = 0;
    VkShaderStageFlags pushStages = 0;
    uint32_t pushSize = 0;
    std::string name;
};

struct BindGroupRes {
    VkDescriptorSet set = VK_NULL_HANDLE;  // sampled textures in READ_ONLY_OPTIMAL (ShaderSampled)
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    uint32_t poolIndex = 0;
    uint32_t setIndex = 0;
    std::string name;
    // What was written, so that variants can be made: a sampled texture whose state maps to
    // GENERAL when the group is bound (e.g. ShaderSampled | ShaderRead) needs a descriptor with
    // that layout. Variants are keyed by the mask of sampled entries that are in GENERAL.
    struct Write {
        uint32_t binding = 0;
        uint32_t arrayElement = 0;
        VkDescriptorType type = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        VkDescriptorBufferInfo buffer{};
        VkDescriptorImageInfo image{};
        TextureHandle sampledTexture;  // valid for sampled-texture entries
        TextureRange sampledRange;     // the mips and layers that entry views
    };
    std::vector<Write> writes;
    struct Variant {
        uint64_t generalMask = 0;
        VkDescriptorSet set = VK_NULL_HANDLE;
        uint32_t poolIndex = 0;
    };
    std::vector<Variant> variants;
};

struct QueryPoolRes {
    VkQueryPool pool = VK_NULL_HANDLE;
    uint32_t count = 0;
};

// The buffer <-> image copy of a resolved region of one subresource, tightly packed at bufferOffset.
VkBufferImageCopy imageCopyRegion(const TextureRes& t, const TextureRegion& box, VkDeviceSize bufferOffset);

// --- command list -----------------------------------------------------------------------------------
class VulkanCommandList final : public CommandList {
public:
    explicit VulkanCommandList(VulkanDevice& device) : m_dev(device) {}

#define RHI_COMMAND_LIST_METHOD(ret, name, params, qualifiers) ret name params qualifiers override;
#include "rhi/command_list_api.inc"
#undef RHI_COMMAND_LIST_METHOD

private:
    friend class VulkanDevice;
    void reset(VkCommandBuffer cmd, std::string_view name);
    bool checkOpen(const char* what);
    bool checkOutsideRenderPass(const char* what);
    bool checkInsideRenderPass(const char* what);
    bool checkPipeline(const char* what, bool graphics);
    void error(const std::string& message);

    VulkanDevice& m_dev;
    VkCommandBuffer m_cmd = VK_NULL_HANDLE;
    bool m_open = false;
    bool m_inRenderPass = false;
    bool m_skippingPass = false;  // beginRenderPass failed: ignore draws until endRenderPass
    bool m_passLabel = false;     // the render pass opened a debug label
    int m_debugDepth = 0;
    std::string m_name;
    // Bound pipeline state (values, not pointers: the pipeline pool may grow while recording).
    bool m_hasPipeline = false;
    bool m_graphics = false;
    VkPipelineLayout m_layout = VK_NULL_HANDLE;
    std::array<VkDescriptorSetLayout, kMaxBindGroups> m_setLayouts{};
    uint32_t m_setCount = 0;
    VkShaderStageFlags m_pushStages = 0;
    uint32_t m_pushSize = 0;
};

// --- device -----------------------------------------------------------------------------------------
class VulkanDevice final : public Device {
public:
    explicit VulkanDevice(const DeviceDesc& desc);
    ~VulkanDevice() override;
    bool init();

    rhi::vulkan::Inspection inspection() const;

#define RHI_DEVICE_METHOD(ret, name, params, qualifiers) ret name params qualifiers override;
#include "rhi/device_api.inc"
#undef RHI_DEVICE_METHOD

private:
    friend class VulkanCommandList;

    static constexpr VkDeviceSize kStagingChunkSize = 8ull << 20;

    struct StagingChunk {
        VkBuffer buffer = VK_NULL_HANDLE;
        Allocation alloc;
        VkDeviceSize size = 0;
        VkDeviceSize used = 0;
    };
    struct StagingSlice {
        VkBuffer buffer = VK_NULL_HANDLE;
        VkDeviceSize offset = 0;
        uint8_t* ptr = nullptr;
    };
    struct Swapchain {
        VkSurfaceKHR surface = VK_NULL_HANDLE;
        VkSwapchainKHR swapchain = VK_NULL_HANDLE;
        VkFormat format = VK_FORMAT_UNDEFINED;
        VkColorSpaceKHR colorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
        VkPresentModeKHR presentMode = VK_PRESENT_MODE_FIFO_KHR;
        VkExtent2D extent{0, 0};
        bool blit = false;  // render into device-owned RGBA8 images, blitted at present()
        std::vector<VkImage> images;
        std::vector<TextureHandle> handles;          // what acquireBackbuffer() hands out, per image
        std::vector<VkSemaphore> renderFinished;     // per image, waited by vkQueuePresentKHR
        std::vector<VkSemaphore> acquireSemaphores;  // ring
        std::vector<uint64_t> acquireSerials;        // submission that waited on each
        uint32_t acquireCursor = 0;
        VkSemaphore pendingAcquire = VK_NULL_HANDLE;  // signalled by acquire, not yet waited on
        uint32_t pendingAcquireSlot = 0;
        int32_t currentImage = -1;
        bool outOfDate = false;
        uint32_t requestedWidth = 0, requestedHeight = 0;
    };

    // logging
    void log(LogSeverity s, const std::string& message) const;
    void logError(const std::string& message) const { log(LogSeverity::Error, message); }
    bool check(VkResult r, const char* what) const;

    // creation helpers
    bool createInstance();
    bool pickPhysicalDevice();
    bool createLogicalDevice();
    void fillInfo();
    void setName(VkObjectType type, uint64_t handle, std::string_view name) const;

    // submission helpers
    VkCommandBuffer acquireCommandBuffer();
    VkCommandBuffer beginInternalCommands();
    struct SemaphoreWait {
        VkSemaphore semaphore;
        VkPipelineStageFlags2 stages;
    };
    // Submits (pending uploads first, then `cbs`), signals the timeline with the next serial and
    // optionally `signalBinary`. Returns the serial, or 0 on failure.
    uint64_t submitBatch(std::span<const VkCommandBuffer> cbs, std::span<const SemaphoreWait> waits,
                         VkSemaphore signalBinary);
    bool waitSerial(uint64_t serial);
    uint64_t completedSerial();
    void recycle();
    bool submitInternalAndWait(VkCommandBuffer cmd);

    // uploads
    VkCommandBuffer uploadCommands();
    bool allocateStaging(VkDeviceSize size, StagingSlice& out);
    void destroyStagingChunk(StagingChunk& c);
    bool createRawBuffer(VkDeviceSize size, VkBufferUsageFlags usage, MemoryType memory, VkBuffer& buffer,
                         Allocation& alloc, const char* what);
    void flushUploadsAndWait();
    void writeTextureImpl(TextureHandle dst, const TextureRegion& region, const void* data, uint64_t size,
                          const char* fn);
    bool readTimestampsImpl(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs, bool wait,
                            const char* fn);

    // resources
    TextureRes* texture(TextureHandle h, const char* what);
    BufferRes* buffer(BufferHandle h, const char* what);
    VkImageView attachmentView(TextureRes& t, uint32_t mip, uint32_t layer);
    // The image's full-dimension view of a resolved range, created once per range.
    VkImageView rangeView(TextureRes& t, const TextureRange& r);
    VkImageView createView(TextureRes& t, VkImageViewType type, uint32_t baseMip, uint32_t mipCount,
                           uint32_t baseLayer, uint32_t layerCount);
    void releaseTexture(TextureRes& t);
    VkDescriptorSetLayout getSetLayout(const std::vector<SetLayoutBinding>& bindings);
    bool allocateDescriptorSet(VkDescriptorSetLayout layout, VkDescriptorSet& set, uint32_t& poolIndex,
                               const std::string& what);
    void writeDescriptors(const BindGroupRes& g, VkDescriptorSet set, uint64_t generalMask);
    // The descriptor set of `g` matching the current layouts of its sampled textures.
    VkDescriptorSet descriptorSetFor(BindGroupRes& g);
    void freeBindGroup(const BindGroupRes& g);
    bool textureImageUsage(const TextureDesc& desc, VkFormat format, const std::string& what,
                           VkImageUsageFlags& usage);
    bool buildPipelineLayout(std::span<const ShaderRes* const> shaders, PipelineRes& out);
    // createGraphicsPipeline's vertex input (every location the vertex shader reads provided, each
    // attribute format usable) and colour targets (formats usable as attachments, blend states);
    // false, with the error logged under `what`, when the description is invalid.
    bool graphicsVertexInput(const GraphicsPipelineDesc& desc, const ShaderRes& vs, const std::string& what,
                             std::vector<VkVertexInputBindingDescription>& bindings,
                             std::vector<VkVertexInputAttributeDescription>& attributes);
    bool graphicsColorTargets(const GraphicsPipelineDesc& desc, const std::string& what,
                              std::vector<VkFormat>& colorFormats,
                              std::vector<VkPipelineColorBlendAttachmentState>& blends);
    // Records a barrier before -> after over `range` (resolved; default: the whole image) and sets
    // the state of those subresources to `after`. `waitForAllWrites` widens the source scope to
    // every earlier write (readback, present blits).
    void recordImageBarrier(VkCommandBuffer cmd, TextureRes& t, Access before, Access after,
                            bool waitForAllWrites = false, const TextureRange* range = nullptr);
    // Moves every subresource of `range` (default: whole image) from its tracked state to `after`.
    void transitionTracked(VkCommandBuffer cmd, TextureRes& t, Access after, bool waitForAllWrites = false,
                           const TextureRange* range = nullptr);
    VkImageLayout layoutOf(const TextureRes& t, Access a) const;

    // swapchain
    bool createSurface();
    bool createSwapchain(uint32_t width, uint32_t height);
    void destroySwapchainImages();
    void destroySwapchain();
    void consumePendingAcquire();

    DeviceDesc m_desc;
    DeviceInfo m_info;
    bool m_ok = false;
    bool m_deviceLost = false;

    VkInstance m_instance = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT m_messenger = VK_NULL_HANDLE;
    VkPhysicalDevice m_physical = VK_NULL_HANDLE;
    VkDevice m_device = VK_NULL_HANDLE;
    VkQueue m_queue = VK_NULL_HANDLE;
    uint32_t m_queueFamily = 0;
    uint32_t m_timestampValidBits = 0;
    VkPhysicalDeviceProperties m_props{};
    bool m_debugUtils = false;
    bool m_validationLayer = false;
    bool m_separateDepthLayouts = false;
    bool m_independentBlend = false;
    bool m_multiDrawIndirect = false;
    // lavapipe takes a timestamp when its gallium context next flushes, which a pipeline barrier
    // does: without barriers around each timestamp, a dispatch's time can be charged to the
    // interval before it (VulkanCommandList::writeTimestamp).
    bool m_barriersAroundTimestamps = false;

    PFN_vkCreateDebugUtilsMessengerEXT m_vkCreateDebugUtilsMessenger = nullptr;
    PFN_vkDestroyDebugUtilsMessengerEXT m_vkDestroyDebugUtilsMessenger = nullptr;
    PFN_vkSetDebugUtilsObjectNameEXT m_vkSetObjectName = nullptr;
    PFN_vkCmdBeginDebugUtilsLabelEXT m_vkCmdBeginLabel = nullptr;
    PFN_vkCmdEndDebugUtilsLabelEXT m_vkCmdEndLabel = nullptr;

    MemoryAllocator m_allocator;

    // submission
    VkSemaphore m_timeline = VK_NULL_HANDLE;
    uint64_t m_nextSerial = 1;
    uint64_t m_lastSubmitted = 0;
    uint64_t m_lastCompleted = 0;
    VkCommandPool m_commandPool = VK_NULL_HANDLE;
    std::vector<VkCommandBuffer> m_freeCommandBuffers;
    std::deque<std::pair<uint64_t, VkCommandBuffer>> m_inflightCommandBuffers;
    std::vector<std::unique_ptr<VulkanCommandList>> m_lists;  // every recorder ever handed out
    std::vector<VulkanCommandList*> m_freeLists;

    // uploads
    VkCommandBuffer m_uploadCmd = VK_NULL_HANDLE;
    std::vector<StagingChunk> m_uploadChunks;  // used by the open upload command buffer
    std::deque<std::pair<uint64_t, StagingChunk>> m_inflightChunks;
    std::vector<StagingChunk> m_freeChunks;

    // descriptors
    std::vector<VkDescriptorPool> m_descriptorPools;
    std::unordered_map<std::string, VkDescriptorSetLayout> m_setLayoutCache;

    detail::DeferredReleaseQueue m_deferred;

    detail::HandlePool<BufferTag, BufferRes> m_buffers;
    detail::HandlePool<TextureTag, TextureRes> m_textures;
    detail::HandlePool<SamplerTag, SamplerRes> m_samplers;
    detail::HandlePool<ShaderTag, ShaderRes> m_shaders;
    detail::HandlePool<PipelineTag, PipelineRes> m_pipelines;
    detail::HandlePool<BindGroupTag, BindGroupRes> m_bindGroups;
    detail::HandlePool<QueryPoolTag, QueryPoolRes> m_queryPools;

    Swapchain m_swapchain;
    DeviceStats m_stats;
    std::array<FormatSupport, size_t(Format::Count)> m_formatSupport{};  // filled by fillInfo()
};

}  // namespace rhi::vk
