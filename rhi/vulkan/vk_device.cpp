// Vulkan backend — instance, physical/logical device, submission, deferred destruction.
#include "rhi/vulkan/vk_device.h"

#include <algorithm>
#include <cstring>

#include "rhi/common/backend_factories.h"
#include "rhi/common/resource_kinds.h"
#include "rhi/validation/validation_device.h"
#include "rhi/vulkan/vk_common.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

namespace rhi {
namespace detail {

std::unique_ptr<Device> createVulkanDevice(const DeviceDesc& desc) {
    auto device = std::make_unique<vk::VulkanDevice>(desc);
    if (!device->init()) return nullptr;
    return device;
}

}  // namespace detail

namespace vulkan {

Inspection inspect(const rhi::Device& device) {
    const auto* vkDevice = dynamic_cast<const vk::VulkanDevice*>(&detail::innermostDevice(device));
    return vkDevice ? vkDevice->inspection() : Inspection{};
}

}  // namespace vulkan

namespace vk {

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                             VkDebugUtilsMessageTypeFlagsEXT types,
                                             const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
    const DeviceDesc* desc = static_cast<const DeviceDesc*>(user);
    // The loader's informational chatter (manifest search, layer insertion) is not worth routing.
    if (severity < VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT &&
        types == VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT)
        return VK_FALSE;
    LogSeverity s = LogSeverity::Debug;
    if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT)
        s = LogSeverity::Error;
    else if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT)
        s = LogSeverity::Warning;
    std::string msg = "[vulkan";
    if (types & VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT)
        msg += " validation";
    else if (types & VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT)
        msg += " performance";
    msg += "] ";
    if (data && data->pMessageIdName) {
        msg += data->pMessageIdName;
        msg += ": ";
    }
    if (data && data->pMessage) msg += data->pMessage;
    detail::logMessage(desc->log, s, msg);
    return VK_FALSE;
}

bool hasExtension(const std::vector<VkExtensionProperties>& exts, const char* name) {
    for (auto& e : exts)
        if (std::strcmp(e.extensionName, name) == 0) return true;
    return false;
}

}  // namespace

VulkanDevice::VulkanDevice(const DeviceDesc& desc) : m_desc(desc) {}

void VulkanDevice::log(LogSeverity s, const std::string& message) const {
    detail::logMessage(m_desc.log, s, "Vulkan: " + message);
}

bool VulkanDevice::check(VkResult r, const char* what) const {
    if (r == VK_SUCCESS) return true;
    logError(std::string(what) + " failed: " + resultString(r));
    return false;
}

void VulkanDevice::setName(VkObjectType type, uint64_t handle, std::string_view name) const {
    if (!m_vkSetObjectName || name.empty() || handle == 0) return;
    std::string n(name);
    auto info = vkInit<VkDebugUtilsObjectNameInfoEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT);
    info.objectType = type;
    info.objectHandle = handle;
    info.pObjectName = n.c_str();
    m_vkSetObjectName(m_device, &info);
}

// ---------------------------------------------------------------------------------------------------
// Creation
// ---------------------------------------------------------------------------------------------------
bool VulkanDevice::init() {
    if (!m_desc.headless && !m_desc.window) {
        logError("a windowed device (headless = false) needs DeviceDesc::window (a GLFWwindow*)");
        return false;
    }
    if (!createInstance()) return false;
    if (!m_desc.headless && !createSurface()) return false;
    if (!pickPhysicalDevice()) return false;
    if (!createLogicalDevice()) return false;
    m_allocator.init(m_physical, m_device);
    fillInfo();

    auto timelineType = vkInit<VkSemaphoreTypeCreateInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO);
    timelineType.semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE;
    timelineType.initialValue = 0;
    auto semInfo = vkInit<VkSemaphoreCreateInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO);
    semInfo.pNext = &timelineType;
    if (!check(vkCreateSemaphore(m_device, &semInfo, nullptr, &m_timeline), "vkCreateSemaphore(timeline)"))
        return false;
    setName(VK_OBJECT_TYPE_SEMAPHORE, uint64_t(m_timeline), "penumbra timeline");

    auto poolInfo = vkInit<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
    poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    poolInfo.queueFamilyIndex = m_queueFamily;
    if (!check(vkCreateCommandPool(m_device, &poolInfo, nullptr, &m_commandPool), "vkCreateCommandPool"))
        return false;

    if (!m_desc.headless) {
        int w = 0, h = 0;
        glfwGetFramebufferSize(static_cast<GLFWwindow*>(m_desc.window), &w, &h);
        if (!createSwapchain(uint32_t(std::max(w, 0)), uint32_t(std::max(h, 0)))) return false;
    }
    m_ok = true;
    log(LogSeverity::Info, "device ready: " + m_info.deviceName + " (" + m_info.apiVersion + ", " +
                               m_info.driverName + " " + m_info.driverVersion + ", " + m_info.platform + ")");
    return true;
}

bool VulkanDevice::createInstance() {
    uint32_t instanceVersion = VK_API_VERSION_1_0;
    if (vkEnumerateInstanceVersion(&instanceVersion) != VK_SUCCESS || instanceVersion < VK_API_VERSION_1_3) {
        logError("the Vulkan loader supports only instance version " + versionString(instanceVersion) +
                 "; Vulkan 1.3 is required");
        return false;
    }

    std::vector<const char*> layers;
    if (m_desc.validation) {
        uint32_t count = 0;
        vkEnumerateInstanceLayerProperties(&count, nullptr);
        std::vector<VkLayerProperties> props(count);
        vkEnumerateInstanceLayerProperties(&count, props.data());
        for (auto& p : props)
            if (std::strcmp(p.layerName, kValidationLayer) == 0) m_validationLayer = true;
        if (m_validationLayer)
            layers.push_back(kValidationLayer);
        else
            log(LogSeverity::Warning, std::string("validation requested but ") + kValidationLayer +
                                          " is not installed (package vulkan-validationlayers); continuing "
                                          "without it");
    }

    uint32_t extCount = 0;
    vkEnumerateInstanceExtensionProperties(nullptr, &extCount, nullptr);
    std::vector<VkExtensionProperties> available(extCount);
    vkEnumerateInstanceExtensionProperties(nullptr, &extCount, available.data());

    std::vector<const char*> extensions;
    m_debugUtils = hasExtension(available, VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    if (m_debugUtils)
        extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    else if (m_desc.validation)
        log(LogSeverity::Warning, "VK_EXT_debug_utils is unavailable: validation messages cannot be routed");

    if (!m_desc.headless) {
        if (!glfwVulkanSupported()) {
            logError("GLFW reports that Vulkan presentation is unsupported (glfwVulkanSupported)");
            return false;
        }
        uint32_t glfwCount = 0;
        const char** glfwExts = glfwGetRequiredInstanceExtensions(&glfwCount);
        if (!glfwExts) {
            logError("glfwGetRequiredInstanceExtensions returned no extensions (was glfwInit called?)");
            return false;
        }
        for (uint32_t i = 0; i < glfwCount; ++i) {
            if (!hasExtension(available, glfwExts[i])) {
                logError(std::string("instance extension ") + glfwExts[i] +
                         " required by GLFW is unavailable");
                return false;
            }
            extensions.push_back(glfwExts[i]);
        }
    }

    auto app = vkInit<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
    app.pApplicationName = "penumbra";
    app.applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0);
    app.pEngineName = "penumbra";
    app.engineVersion = VK_MAKE_API_VERSION(0, 0, 1, 0);
    app.apiVersion = VK_API_VERSION_1_3;

    auto messengerInfo =
        vkInit<VkDebugUtilsMessengerCreateInfoEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT);
    messengerInfo.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_INFO_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                                VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    messengerInfo.pfnUserCallback = debugCallback;
    messengerInfo.pUserData = &m_desc;
    const bool useMessenger = m_desc.validation && m_debugUtils;

    auto info = vkInit<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
    info.pNext = useMessenger ? &messengerInfo : nullptr;  // also covers vkCreate/DestroyInstance
    info.pApplicationInfo = &app;
    info.enabledLayerCount = uint32_t(layers.size());
    info.ppEnabledLayerNames = layers.data();
    info.enabledExtensionCount = uint32_t(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    VkResult r = vkCreateInstance(&info, nullptr, &m_instance);
    if (r != VK_SUCCESS) {
        logError(std::string("vkCreateInstance failed: ") + resultString(r));
        m_instance = VK_NULL_HANDLE;
        return false;
    }

    if (m_debugUtils) {
        m_vkCreateDebugUtilsMessenger = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(m_instance, "vkCreateDebugUtilsMessengerEXT"));
        m_vkDestroyDebugUtilsMessenger = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(m_instance, "vkDestroyDebugUtilsMessengerEXT"));
        m_vkSetObjectName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
            vkGetInstanceProcAddr(m_instance, "vkSetDebugUtilsObjectNameEXT"));
        m_vkCmdBeginLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
            vkGetInstanceProcAddr(m_instance, "vkCmdBeginDebugUtilsLabelEXT"));
        m_vkCmdEndLabel = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(
            vkGetInstanceProcAddr(m_instance, "vkCmdEndDebugUtilsLabelEXT"));
    }
    if (useMessenger && m_vkCreateDebugUtilsMessenger) {
        r = m_vkCreateDebugUtilsMessenger(m_instance, &messengerInfo, nullptr, &m_messenger);
        if (r != VK_SUCCESS) {
            log(LogSeverity::Warning,
                std::string("vkCreateDebugUtilsMessengerEXT failed: ") + resultString(r));
            m_messenger = VK_NULL_HANDLE;
        }
    }
    if (m_desc.validation) {
        log(LogSeverity::Info,
            std::string("validation layer ") +
                (m_validationLayer ? "VK_LAYER_KHRONOS_validation enabled" : "unavailable") +
                ", debug-utils messenger " + (m_messenger ? "installed" : "not installed"));
    }
    return true;
}

bool VulkanDevice::createSurface() {
    VkResult r = glfwCreateWindowSurface(m_instance, static_cast<GLFWwindow*>(m_desc.window), nullptr,
                                         &m_swapchain.surface);
    if (r != VK_SUCCESS) {
        logError(std::string("glfwCreateWindowSurface failed: ") + resultString(r) +
                 " (create the window with GLFW_CLIENT_API = GLFW_NO_API)");
        m_swapchain.surface = VK_NULL_HANDLE;
        return false;
    }
    return true;
}

bool VulkanDevice::pickPhysicalDevice() {
    uint32_t count = 0;
    vkEnumeratePhysicalDevices(m_instance, &count, nullptr);
    std::vector<VkPhysicalDevice> devices(count);
    vkEnumeratePhysicalDevices(m_instance, &count, devices.data());
    if (devices.empty()) {
        logError("no Vulkan physical device found");
        return false;
    }

    struct Candidate {
        VkPhysicalDevice device;
        uint32_t family;
        bool discrete;
    };
    std::vector<Candidate> candidates;
    std::string rejected;
    for (VkPhysicalDevice pd : devices) {
        VkPhysicalDeviceProperties props;
        vkGetPhysicalDeviceProperties(pd, &props);
        if (props.apiVersion < VK_API_VERSION_1_3) {
            rejected +=
                std::string(" ") + props.deviceName + " (Vulkan " + versionString(props.apiVersion) + ")";
            continue;
        }
        uint32_t qCount = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(pd, &qCount, nullptr);
        std::vector<VkQueueFamilyProperties> families(qCount);
        vkGetPhysicalDeviceQueueFamilyProperties(pd, &qCount, families.data());
        int family = -1;
        for (uint32_t i = 0; i < qCount && family < 0; ++i) {
            const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
            if ((families[i].queueFlags & need) != need) continue;
            if (m_swapchain.surface) {
                VkBool32 present = VK_FALSE;
                vkGetPhysicalDeviceSurfaceSupportKHR(pd, i, m_swapchain.surface, &present);
                if (!present) continue;
            }
            family = int(i);
        }
        if (family < 0) {
            rejected += std::string(" ") + props.deviceName + " (no graphics+compute" +
                        (m_swapchain.surface ? "+present" : "") + " queue)";
            continue;
        }
        candidates.push_back(
            {pd, uint32_t(family), props.deviceType == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU});
    }
    if (candidates.empty()) {
        logError("no suitable Vulkan 1.3 device; rejected:" + rejected);
        return false;
    }
    auto it =
        std::find_if(candidates.begin(), candidates.end(), [](const Candidate& c) { return c.discrete; });
    const Candidate& c = it != candidates.end() ? *it : candidates.front();
    m_physical = c.device;
    m_queueFamily = c.family;
    vkGetPhysicalDeviceProperties(m_physical, &m_props);

    uint32_t qCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(m_physical, &qCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(qCount);
    vkGetPhysicalDeviceQueueFamilyProperties(m_physical, &qCount, families.data());
    m_timestampValidBits = families[m_queueFamily].timestampValidBits;
    return true;
}

bool VulkanDevice::createLogicalDevice() {
    auto f13 =
        vkInit<VkPhysicalDeviceVulkan13Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
    auto f12 =
        vkInit<VkPhysicalDeviceVulkan12Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES);
    auto f11 =
        vkInit<VkPhysicalDeviceVulkan11Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES);
    auto f2 = vkInit<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
    f2.pNext = &f11;
    f11.pNext = &f12;
    f12.pNext = &f13;
    vkGetPhysicalDeviceFeatures2(m_physical, &f2);

    std::string missing;
    if (!f13.synchronization2) missing += " synchronization2";
    if (!f13.dynamicRendering) missing += " dynamicRendering";
    if (!f12.timelineSemaphore) missing += " timelineSemaphore";
    if (!missing.empty()) {
        logError(std::string("device '") + m_props.deviceName +
                 "' lacks required Vulkan 1.3 features:" + missing);
        return false;
    }

    // Required features, plus optional ones enabled only where queried as supported; their names
    // go to DeviceInfo::enabledFeatures and the log.
    auto e13 =
        vkInit<VkPhysicalDeviceVulkan13Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
    e13.synchronization2 = VK_TRUE;
    e13.dynamicRendering = VK_TRUE;
    auto e12 =
        vkInit<VkPhysicalDeviceVulkan12Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES);
    e12.pNext = &e13;
    e12.timelineSemaphore = VK_TRUE;
    auto e11 =
        vkInit<VkPhysicalDeviceVulkan11Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES);
    e11.pNext = &e12;
    auto e2 = vkInit<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
    e2.pNext = &e11;
    const VkPhysicalDeviceFeatures& a = f2.features;
    VkPhysicalDeviceFeatures& e = e2.features;
    struct Optional {
        const char* name;
        VkBool32 supported;
        VkBool32* enable;
    };
#define PENUMBRA_VK_OPTIONAL(queried, enabled, member) \
    { #member, queried.member, &enabled.member }
    const Optional optional[] = {
        PENUMBRA_VK_OPTIONAL(f13, e13, maintenance4),
        PENUMBRA_VK_OPTIONAL(f12, e12, separateDepthStencilLayouts),
        PENUMBRA_VK_OPTIONAL(f12, e12, hostQueryReset),
        PENUMBRA_VK_OPTIONAL(f12, e12, scalarBlockLayout),
        PENUMBRA_VK_OPTIONAL(f12, e12, uniformBufferStandardLayout),
        PENUMBRA_VK_OPTIONAL(f12, e12, shaderFloat16),
        PENUMBRA_VK_OPTIONAL(f12, e12, shaderInt8),
        PENUMBRA_VK_OPTIONAL(f12, e12, storageBuffer8BitAccess),
        PENUMBRA_VK_OPTIONAL(f12, e12, drawIndirectCount),
        PENUMBRA_VK_OPTIONAL(f11, e11, shaderDrawParameters),
        PENUMBRA_VK_OPTIONAL(f11, e11, storageBuffer16BitAccess),
        PENUMBRA_VK_OPTIONAL(a, e, independentBlend),
        PENUMBRA_VK_OPTIONAL(a, e, multiDrawIndirect),
        PENUMBRA_VK_OPTIONAL(a, e, drawIndirectFirstInstance),
        PENUMBRA_VK_OPTIONAL(a, e, fragmentStoresAndAtomics),
        PENUMBRA_VK_OPTIONAL(a, e, vertexPipelineStoresAndAtomics),
        PENUMBRA_VK_OPTIONAL(a, e, shaderStorageImageExtendedFormats),
        PENUMBRA_VK_OPTIONAL(a, e, shaderStorageImageReadWithoutFormat),
        PENUMBRA_VK_OPTIONAL(a, e, shaderStorageImageWriteWithoutFormat),
        PENUMBRA_VK_OPTIONAL(a, e, shaderInt16),
        PENUMBRA_VK_OPTIONAL(a, e, shaderInt64),
        PENUMBRA_VK_OPTIONAL(a, e, shaderFloat64),
        PENUMBRA_VK_OPTIONAL(a, e, depthClamp),
        PENUMBRA_VK_OPTIONAL(a, e, fillModeNonSolid),
        PENUMBRA_VK_OPTIONAL(a, e, samplerAnisotropy),
        PENUMBRA_VK_OPTIONAL(a, e, imageCubeArray),
        PENUMBRA_VK_OPTIONAL(a, e, shaderClipDistance),
    };
#undef PENUMBRA_VK_OPTIONAL
    m_info.enabledFeatures.clear();
    std::string enabledList;
    for (const Optional& o : optional) {
        *o.enable = o.supported;
        if (!o.supported) continue;
        m_info.enabledFeatures.emplace_back(o.name);
        enabledList += std::string(enabledList.empty() ? "" : " ") + o.name;
    }
    log(LogSeverity::Debug,
        "optional device features enabled: " + (enabledList.empty() ? "none" : enabledList));
    m_separateDepthLayouts = f12.separateDepthStencilLayouts;
    m_independentBlend = a.independentBlend;
    m_multiDrawIndirect = a.multiDrawIndirect;
    m_barriersAroundTimestamps = std::string(m_props.deviceName).find("llvmpipe") != std::string::npos;

    uint32_t extCount = 0;
    vkEnumerateDeviceExtensionProperties(m_physical, nullptr, &extCount, nullptr);
    std::vector<VkExtensionProperties> available(extCount);
    vkEnumerateDeviceExtensionProperties(m_physical, nullptr, &extCount, available.data());
    std::vector<const char*> extensions;
    if (!m_desc.headless) {
        if (!hasExtension(available, VK_KHR_SWAPCHAIN_EXTENSION_NAME)) {
            logError(std::string("device '") + m_props.deviceName + "' lacks VK_KHR_swapchain");
            return false;
        }
        extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    }

    const float priority = 1.0f;
    auto queueInfo = vkInit<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
    queueInfo.queueFamilyIndex = m_queueFamily;
    queueInfo.queueCount = 1;
    queueInfo.pQueuePriorities = &priority;

    auto info = vkInit<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
    info.pNext = &e2;
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &queueInfo;
    info.enabledExtensionCount = uint32_t(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    VkResult r = vkCreateDevice(m_physical, &info, nullptr, &m_device);
    if (r != VK_SUCCESS) {
        logError(std::string("vkCreateDevice failed: ") + resultString(r));
        m_device = VK_NULL_HANDLE;
        return false;
    }
    vkGetDeviceQueue(m_device, m_queueFamily, 0, &m_queue);
    return true;
}

void VulkanDevice::fillInfo() {
    auto subgroup =
        vkInit<VkPhysicalDeviceSubgroupProperties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES);
    auto driver =
        vkInit<VkPhysicalDeviceDriverProperties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES);
    driver.pNext = &subgroup;
    auto props2 = vkInit<VkPhysicalDeviceProperties2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
    props2.pNext = &driver;
    vkGetPhysicalDeviceProperties2(m_physical, &props2);

    m_info.backend = Backend::Vulkan;
    m_info.apiVersion = "Vulkan " + versionString(m_props.apiVersion);
    m_info.deviceName = m_props.deviceName;
    m_info.driverName = driver.driverName;
    m_info.driverVersion = driver.driverInfo;
    if (m_info.driverVersion.empty()) m_info.driverVersion = std::to_string(m_props.driverVersion);
    m_info.platform = m_desc.headless ? "headless" : "GLFW window";

    const VkPhysicalDeviceLimits& l = m_props.limits;
    DeviceLimits& d = m_info.limits;
    d.maxTextureSize2D = l.maxImageDimension2D;
    d.maxTextureSize3D = l.maxImageDimension3D;
    d.maxTextureArrayLayers = l.maxImageArrayLayers;
    for (int i = 0; i < 3; ++i) {
        d.maxComputeWorkgroupCount[i] = l.maxComputeWorkGroupCount[i];
        d.maxComputeWorkgroupSize[i] = l.maxComputeWorkGroupSize[i];
    }
    d.maxComputeWorkgroupInvocations = l.maxComputeWorkGroupInvocations;
    d.maxStorageBufferRange = l.maxStorageBufferRange;
    d.maxUniformBufferRange = l.maxUniformBufferRange;
    d.maxPushConstantSize = std::min<uint32_t>(kMaxPushConstantSize, l.maxPushConstantsSize);
    d.maxBindGroups = std::min<uint32_t>(kMaxBindGroups, l.maxBoundDescriptorSets);
    d.maxColorTargets = std::min<uint32_t>(kMaxColorTargets, l.maxColorAttachments);
    d.timestampPeriodNs = double(l.timestampPeriod);
    d.timestamps = l.timestampComputeAndGraphics == VK_TRUE && m_timestampValidBits > 0;
    // SPIR-V DepthGreater / DepthLess / DepthUnchanged execution modes are core Vulkan.
    d.conservativeDepth = true;
    // VkSubgroupFeatureFlagBits and rhi::SubgroupOps share their bit order (basic .. quad).
    d.subgroupSize = subgroup.subgroupSize;
    d.subgroupOps = SubgroupOps(subgroup.supportedOperations & 0xffu);
    if (subgroup.supportedStages & VK_SHADER_STAGE_VERTEX_BIT) d.subgroupStages |= ShaderStageFlags::Vertex;
    if (subgroup.supportedStages & VK_SHADER_STAGE_FRAGMENT_BIT)
        d.subgroupStages |= ShaderStageFlags::Fragment;
    if (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) d.subgroupStages |= ShaderStageFlags::Compute;

    for (uint32_t f = 1; f < uint32_t(Format::Count); ++f) {
        const VkFormat vf = toVkFormat(Format(f));
        if (vf == VK_FORMAT_UNDEFINED) continue;
        VkFormatProperties fp{};
        vkGetPhysicalDeviceFormatProperties(m_physical, vf, &fp);
        const VkFormatFeatureFlags t = fp.optimalTilingFeatures;
        FormatSupport s = FormatSupport::None;
        auto add = [&](bool has, FormatSupport bit) {
            if (has) s |= bit;
        };
        add(t & VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT, FormatSupport::Sampled);
        add(t & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT, FormatSupport::Filterable);
        add(t & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT, FormatSupport::Storage);
        add(t & VK_FORMAT_FEATURE_STORAGE_IMAGE_ATOMIC_BIT, FormatSupport::StorageAtomic);
        add(t & VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT, FormatSupport::ColorTarget);
        add(t & VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BLEND_BIT, FormatSupport::Blendable);
        add(t & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT, FormatSupport::DepthTarget);
        add(fp.bufferFeatures & VK_FORMAT_FEATURE_VERTEX_BUFFER_BIT, FormatSupport::VertexAttribute);
        // RGB32_FLOAT is a vertex format only in the RHI (createTexture refuses it).
        if (Format(f) == Format::RGB32_FLOAT) s &= FormatSupport::VertexAttribute;
        m_formatSupport[f] = s;
    }
}

rhi::vulkan::Inspection VulkanDevice::inspection() const {
    rhi::vulkan::Inspection i;
    i.isVulkan = true;
    i.validationLayerEnabled = m_validationLayer;
    i.debugMessengerInstalled = m_messenger != VK_NULL_HANDLE;
    i.liveObjects = m_buffers.size() + m_textures.size() + m_samplers.size() + m_shaders.size() +
                    m_pipelines.size() + m_bindGroups.size() + m_queryPools.size();
    i.pendingReleases = m_deferred.pending();
    i.allocatedBytes = m_allocator.allocatedBytes();
    i.memoryBlocks = m_allocator.blockCount();
    i.lastSubmittedSerial = m_lastSubmitted;
    return i;
}

// ---------------------------------------------------------------------------------------------------
// Destruction
// ---------------------------------------------------------------------------------------------------
VulkanDevice::~VulkanDevice() {
    if (m_device) {
        if (m_swapchain.pendingAcquire && !m_deviceLost) consumePendingAcquire();
        if (m_uploadCmd && !m_deviceLost) submitBatch({}, {}, VK_NULL_HANDLE);
        vkDeviceWaitIdle(m_device);
        m_lastCompleted = m_lastSubmitted;
        destroySwapchain();
        m_deferred.releaseAll();

        size_t leaked = m_buffers.size() + m_textures.size() + m_samplers.size() + m_shaders.size() +
                        m_pipelines.size() + m_bindGroups.size() + m_queryPools.size();
        if (leaked)
            log(LogSeverity::Debug, std::to_string(leaked) +
                                        " object(s) still alive at device destruction; "
                                        "releasing them");
        m_bindGroups.forEach([&](BindGroupHandle, BindGroupRes& g) { freeBindGroup(g); });
        m_pipelines.forEach([&](PipelineHandle, PipelineRes& p) {
            vkDestroyPipeline(m_device, p.pipeline, nullptr);
            vkDestroyPipelineLayout(m_device, p.layout, nullptr);
        });
        m_shaders.forEach(
            [&](ShaderHandle, ShaderRes& s) { vkDestroyShaderModule(m_device, s.module, nullptr); });
        m_samplers.forEach(
            [&](SamplerHandle, SamplerRes& s) { vkDestroySampler(m_device, s.sampler, nullptr); });
        m_queryPools.forEach(
            [&](QueryPoolHandle, QueryPoolRes& q) { vkDestroyQueryPool(m_device, q.pool, nullptr); });
        m_textures.forEach([&](TextureHandle, TextureRes& t) { releaseTexture(t); });
        m_buffers.forEach([&](BufferHandle, BufferRes& b) {
            vkDestroyBuffer(m_device, b.buffer, nullptr);
            m_allocator.free(b.alloc);
        });

        for (auto& c : m_uploadChunks) destroyStagingChunk(c);
        for (auto& [serial, c] : m_inflightChunks) destroyStagingChunk(c);
        for (auto& c : m_freeChunks) destroyStagingChunk(c);
        m_uploadChunks.clear();
        m_inflightChunks.clear();
        m_freeChunks.clear();

        for (auto& [key, layout] : m_setLayoutCache) vkDestroyDescriptorSetLayout(m_device, layout, nullptr);
        for (VkDescriptorPool p : m_descriptorPools) vkDestroyDescriptorPool(m_device, p, nullptr);
        if (m_commandPool) vkDestroyCommandPool(m_device, m_commandPool, nullptr);
        if (m_timeline) vkDestroySemaphore(m_device, m_timeline, nullptr);
        m_allocator.shutdown();
        vkDestroyDevice(m_device, nullptr);
    }
    if (m_instance) {
        if (m_swapchain.surface) vkDestroySurfaceKHR(m_instance, m_swapchain.surface, nullptr);
        if (m_messenger) m_vkDestroyDebugUtilsMessenger(m_instance, m_messenger, nullptr);
        vkDestroyInstance(m_instance, nullptr);
    }
}

// ---------------------------------------------------------------------------------------------------
// Submission
// ---------------------------------------------------------------------------------------------------
uint64_t VulkanDevice::completedSerial() {
    if (m_deviceLost) {
        m_lastCompleted = m_lastSubmitted;
        return m_lastCompleted;
    }
    uint64_t value = 0;
    VkResult r = vkGetSemaphoreCounterValue(m_device, m_timeline, &value);
    if (r == VK_ERROR_DEVICE_LOST) {
        m_deviceLost = true;
        logError("device lost (vkGetSemaphoreCounterValue)");
        m_lastCompleted = m_lastSubmitted;
    } else if (r == VK_SUCCESS) {
        m_lastCompleted = std::max(m_lastCompleted, value);
    }
    return m_lastCompleted;
}

void VulkanDevice::recycle() {
    const uint64_t done = completedSerial();
    while (!m_inflightCommandBuffers.empty() && m_inflightCommandBuffers.front().first <= done) {
        m_freeCommandBuffers.push_back(m_inflightCommandBuffers.front().second);
        m_inflightCommandBuffers.pop_front();
    }
    constexpr size_t kMaxFreeChunks = 4;
    while (!m_inflightChunks.empty() && m_inflightChunks.front().first <= done) {
        StagingChunk c = m_inflightChunks.front().second;
        m_inflightChunks.pop_front();
        if (c.size == kStagingChunkSize && m_freeChunks.size() < kMaxFreeChunks) {
            c.used = 0;
            m_freeChunks.push_back(c);
        } else {
            destroyStagingChunk(c);
        }
    }
}

VkCommandBuffer VulkanDevice::acquireCommandBuffer() {
    recycle();
    if (!m_freeCommandBuffers.empty()) {
        VkCommandBuffer cb = m_freeCommandBuffers.back();
        m_freeCommandBuffers.pop_back();
        return cb;
    }
    auto info = vkInit<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    info.commandPool = m_commandPool;
    info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    info.commandBufferCount = 1;
    VkCommandBuffer cb = VK_NULL_HANDLE;
    if (!check(vkAllocateCommandBuffers(m_device, &info, &cb), "vkAllocateCommandBuffers"))
        return VK_NULL_HANDLE;
    return cb;
}

VkCommandBuffer VulkanDevice::beginInternalCommands() {
    VkCommandBuffer cb = acquireCommandBuffer();
    if (!cb) return VK_NULL_HANDLE;
    auto begin = vkInit<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    if (!check(vkBeginCommandBuffer(cb, &begin), "vkBeginCommandBuffer")) {
        m_freeCommandBuffers.push_back(cb);
        return VK_NULL_HANDLE;
    }
    return cb;
}

uint64_t VulkanDevice::submitBatch(std::span<const VkCommandBuffer> cbs, std::span<const SemaphoreWait> waits,
                                   VkSemaphore signalBinary) {
    std::vector<VkCommandBuffer> all;
    if (m_uploadCmd) {
        // Make the uploads visible to everything that follows on the queue.
        cmdMemoryBarrier(m_uploadCmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                         VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
        check(vkEndCommandBuffer(m_uploadCmd), "vkEndCommandBuffer(uploads)");
        all.push_back(m_uploadCmd);
    }
    all.insert(all.end(), cbs.begin(), cbs.end());

    std::vector<VkCommandBufferSubmitInfo> cbInfos;
    for (VkCommandBuffer cb : all) {
        auto ci = vkInit<VkCommandBufferSubmitInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO);
        ci.commandBuffer = cb;
        cbInfos.push_back(ci);
    }
    std::vector<VkSemaphoreSubmitInfo> waitInfos;
    for (const SemaphoreWait& w : waits) {
        auto si = vkInit<VkSemaphoreSubmitInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO);
        si.semaphore = w.semaphore;
        si.stageMask = w.stages;
        waitInfos.push_back(si);
    }
    const uint64_t serial = m_nextSerial;
    VkSemaphoreSubmitInfo signals[2];
    signals[0] = vkInit<VkSemaphoreSubmitInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO);
    signals[0].semaphore = m_timeline;
    signals[0].value = serial;
    signals[0].stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    uint32_t signalCount = 1;
    if (signalBinary) {
        signals[1] = vkInit<VkSemaphoreSubmitInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO);
        signals[1].semaphore = signalBinary;
        signals[1].stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
        signalCount = 2;
    }

    auto submit = vkInit<VkSubmitInfo2>(VK_STRUCTURE_TYPE_SUBMIT_INFO_2);
    submit.waitSemaphoreInfoCount = uint32_t(waitInfos.size());
    submit.pWaitSemaphoreInfos = waitInfos.data();
    submit.commandBufferInfoCount = uint32_t(cbInfos.size());
    submit.pCommandBufferInfos = cbInfos.data();
    submit.signalSemaphoreInfoCount = signalCount;
    submit.pSignalSemaphoreInfos = signals;
    VkResult r = m_deviceLost ? VK_ERROR_DEVICE_LOST : vkQueueSubmit2(m_queue, 1, &submit, VK_NULL_HANDLE);

    if (m_uploadCmd) {
        for (auto& c : m_uploadChunks) m_inflightChunks.emplace_back(r == VK_SUCCESS ? serial : 0, c);
        m_uploadChunks.clear();
        m_uploadCmd = VK_NULL_HANDLE;
    }
    if (r != VK_SUCCESS) {
        if (r == VK_ERROR_DEVICE_LOST) {
            if (!m_deviceLost) logError("device lost (vkQueueSubmit2)");
            m_deviceLost = true;
        } else {
            logError(std::string("vkQueueSubmit2 failed: ") + resultString(r));
        }
        for (VkCommandBuffer cb : all) m_freeCommandBuffers.push_back(cb);
        return 0;
    }
    for (VkCommandBuffer cb : all) m_inflightCommandBuffers.emplace_back(serial, cb);
    m_lastSubmitted = serial;
    ++m_nextSerial;
    return serial;
}

bool VulkanDevice::waitSerial(uint64_t serial) {
    if (serial == 0 || serial <= m_lastCompleted) return true;
    if (serial > m_lastSubmitted) {
        logError("waitForSubmission(" + std::to_string(serial) +
                 "): that serial was never submitted (last is " + std::to_string(m_lastSubmitted) + ")");
        return false;
    }
    if (m_deviceLost) return false;
    auto info = vkInit<VkSemaphoreWaitInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO);
    info.semaphoreCount = 1;
    info.pSemaphores = &m_timeline;
    info.pValues = &serial;
    VkResult r = vkWaitSemaphores(m_device, &info, UINT64_MAX);
    if (r != VK_SUCCESS) {
        if (r == VK_ERROR_DEVICE_LOST) m_deviceLost = true;
        logError(std::string("vkWaitSemaphores failed: ") + resultString(r));
        return false;
    }
    m_lastCompleted = std::max(m_lastCompleted, serial);
    return true;
}

bool VulkanDevice::submitInternalAndWait(VkCommandBuffer cmd) {
    if (!check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer")) {
        m_freeCommandBuffers.push_back(cmd);
        return false;
    }
    const VkCommandBuffer cbs[1] = {cmd};
    uint64_t serial = submitBatch(cbs, {}, VK_NULL_HANDLE);
    if (serial == 0) return false;
    bool ok = waitSerial(serial);
    collectGarbage();
    return ok;
}

CommandList& VulkanDevice::beginCommandList(std::string_view debugName) {
    VulkanCommandList* list = nullptr;
    if (!m_freeLists.empty()) {
        list = m_freeLists.back();
        m_freeLists.pop_back();
    } else {
        m_lists.push_back(std::make_unique<VulkanCommandList>(*this));
        list = m_lists.back().get();
    }
    VkCommandBuffer cb = m_ok ? acquireCommandBuffer() : VK_NULL_HANDLE;
    if (cb) {
        auto begin = vkInit<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        if (!check(vkBeginCommandBuffer(cb, &begin), "vkBeginCommandBuffer")) {
            m_freeCommandBuffers.push_back(cb);
            cb = VK_NULL_HANDLE;
        }
    }
    if (cb) setName(VK_OBJECT_TYPE_COMMAND_BUFFER, uint64_t(cb), debugName);
    // A list without a command buffer records nothing (each call logs) and submits nothing.
    list->reset(cb, debugName);
    return *list;
}

uint64_t VulkanDevice::submit(CommandList& listIn) {
    VulkanCommandList* list = nullptr;
    for (auto& l : m_lists)
        if (l.get() == &listIn) list = l.get();
    if (!list) {
        logError("submit(): the command list does not belong to this device");
        return 0;
    }
    if (!list->m_open) {
        logError("submit(): the command list '" + list->m_name + "' was already submitted");
        return 0;
    }
    VkCommandBuffer cb = list->m_cmd;
    if (list->m_inRenderPass) {
        logError("submit(): command list '" + list->m_name + "' ends inside a render pass; ending it");
        vkCmdEndRendering(cb);
        if (list->m_passLabel) m_vkCmdEndLabel(cb);
    }
    list->m_inRenderPass = list->m_skippingPass = list->m_passLabel = false;
    if (m_vkCmdEndLabel)
        for (; list->m_debugDepth > 0; --list->m_debugDepth) m_vkCmdEndLabel(cb);
    list->m_open = false;
    list->m_cmd = VK_NULL_HANDLE;
    m_freeLists.push_back(list);
    if (!cb) return 0;

    if (!check(vkEndCommandBuffer(cb), "vkEndCommandBuffer")) {
        m_freeCommandBuffers.push_back(cb);
        return 0;
    }
    // The first submission after acquiring a swapchain image that is rendered to directly waits
    // for the presentation engine to release it.
    std::vector<SemaphoreWait> waits;
    uint32_t waitedSlot = 0;
    if (m_swapchain.pendingAcquire && !m_swapchain.blit) {
        waits.push_back({m_swapchain.pendingAcquire, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT});
        waitedSlot = m_swapchain.pendingAcquireSlot;
    }
    const VkCommandBuffer cbs[1] = {cb};
    uint64_t serial = submitBatch(cbs, waits, VK_NULL_HANDLE);
    if (serial && !waits.empty()) {
        m_swapchain.acquireSerials[waitedSlot] = serial;
        m_swapchain.pendingAcquire = VK_NULL_HANDLE;
    }
    collectGarbage();
    return serial ? serial : m_lastSubmitted;
}

void VulkanDevice::waitForSubmission(uint64_t serial) {
    waitSerial(serial);
    collectGarbage();
}

void VulkanDevice::waitIdle() {
    if (!m_device) return;
    if (m_uploadCmd) submitBatch({}, {}, VK_NULL_HANDLE);
    if (!m_deviceLost) {
        VkResult r = vkDeviceWaitIdle(m_device);
        if (r == VK_ERROR_DEVICE_LOST) {
            m_deviceLost = true;
            logError("device lost (vkDeviceWaitIdle)");
        }
    }
    m_lastCompleted = std::max(m_lastCompleted, m_lastSubmitted);
    recycle();
    m_deferred.releaseAll();
}

void VulkanDevice::collectGarbage() {
    if (!m_device) return;
    m_deferred.collect(completedSerial());
    recycle();
}

void VulkanDevice::flushUploadsAndWait() {
    if (!m_uploadCmd) return;
    uint64_t serial = submitBatch({}, {}, VK_NULL_HANDLE);
    waitSerial(serial);
}

// Inline-sized overrides (declared from rhi/device_api.inc).
const DeviceInfo& VulkanDevice::info() const { return m_info; }
#define RHI_IS_ALIVE(Handle, pool, name) \
    bool VulkanDevice::isAlive(Handle h) const { return pool.contains(h); }
RHI_RESOURCE_KINDS(RHI_IS_ALIVE)
#undef RHI_IS_ALIVE
DeviceStats VulkanDevice::stats() const { return m_stats; }
FormatSupport VulkanDevice::formatSupport(Format format) const {
    return format < Format::Count ? m_formatSupport[size_t(format)] : FormatSupport::None;
}

}  // namespace vk
}  // namespace rhi
