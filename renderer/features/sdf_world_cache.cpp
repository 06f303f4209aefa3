#include "renderer/features/sdf_world_cache.h"

#include <algorithm>
#include <cstring>

#include <fmt/format.h>
#include <shaders/sdf_world_cache_update.h>

#include "renderer/features/scene_upload.h"

namespace penumbra::render {
namespace {

namespace program = shaders::sdf_world_cache_update;
// The objects' uniform block holds kSdfObjectsUniformCapacity records (sdf_scene.glsl).
static_assert(sizeof(program::SdfObjectsUniform) == kSdfObjectsUniformCapacity * sizeof(GpuSdfObject));

// The clipmap (an engine-free module) keeps defaults of its own; they are the scene's.
constexpr ClipmapSettings kClipmapDefaults{};
constexpr scene::AccelerationSettings kSceneDefaults{};
static_assert(kClipmapDefaults.levels == kSceneDefaults.cacheLevels &&
                  kClipmapDefaults.resolution == kSceneDefaults.cacheResolution &&
                  kClipmapDefaults.voxel == kSceneDefaults.cacheVoxel &&
                  kClipmapDefaults.budgetVoxels == kSceneDefaults.cacheBudgetVoxels,
              "ClipmapSettings' defaults must equal scene::AccelerationSettings' cache defaults");

constexpr uint32_t kMaxGroupsPerDispatch = 65535;
constexpr uint32_t kExactProgram = 1u;  // CacheObjectFlags: the shape program's value is exact

struct UpdateData {
    SdfSceneBuffers sdf;
    SdfWorldCacheView view;
    fg::BufferRef jobs, list, flags;
};

// An analytic program whose value is an upper bound of the true signed distance as well as a
// lower one (shapes are exact, so are transforms; a union never overestimates |d| inside and is
// exact outside, so its value is >= the true signed distance): only shapes, unions and transforms.
bool exactProgram(const std::vector<sdf::ShapeInstruction>& records, uint32_t first) {
    if (first >= records.size()) return false;
    const uint32_t count = records[first].i[1];
    if (count > records.size() - first - 1) return false;
    for (uint32_t k = first + 1; k <= first + count; ++k) {
        const uint32_t op = records[k].op;
        const bool shape = op >= uint32_t(sdf::ShapeOp::Sphere) && op <= uint32_t(sdf::ShapeOp::Plane);
        if (!shape && op != uint32_t(sdf::ShapeOp::Union) && op != uint32_t(sdf::ShapeOp::PushTransform) &&
            op != uint32_t(sdf::ShapeOp::PopTransform))
            return false;
    }
    return true;
}

// Per-frame buffer sizes rounded up to a power of two (at least 4 KiB): the graph's pool reuses a
// buffer of the same size, so frames with varying job counts create no new buffers or bind groups.
uint64_t pooledSize(uint64_t bytes) {
    uint64_t size = 4096;
    while (size < bytes) size *= 2;
    return size;
}

rhi::SamplerHandle nearestSampler(GpuCache& cache) {
    rhi::SamplerDesc d;  // integer textures need nearest filtering to be complete on GL
    d.minFilter = d.magFilter = rhi::Filter::Nearest;
    d.maxLod = 0.0f;
    d.debugName = "sdf.cache";
    return cache.sampler(d);
}

// One compute pass over jobs [first, first + count) of the frame's job buffer: one workgroup per
// job, or (packedVoxels > 0, the splat jobs) one invocation per voxel of their concatenated boxes.
void addUpdatePass(FrameContext& fc, const char* name, const UpdateData& in, uint32_t first, uint32_t count,
                   uint32_t objectCount, uint32_t packedVoxels = 0) {
    const uint64_t objectsUniform = sdfObjectsUniformBytes(fc.device.info(), in.sdf.objectCount);
    const rhi::ShaderDesc& cs =
        program::compute(sdfSceneVariant<program::Variant>(in.sdf, objectsUniform > 0));
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle atlasSampler = sdfAtlasSampler(fc.cache, in.sdf);
    fc.graph.addPass<UpdateData>(
        name, fg::PassKind::Compute,
        [&](fg::PassBuilder& b, UpdateData& d) {
            d = in;
            readSdfScene(b, d.sdf, objectsUniform > 0);
            b.read(d.jobs, rhi::Access::ShaderRead);
            b.read(d.list, rhi::Access::ShaderRead);
            b.read(d.flags, rhi::Access::ShaderRead);
            b.read(d.view.levels, rhi::Access::ShaderRead);
            const rhi::Access rw = rhi::Access::ShaderRead | rhi::Access::ShaderWrite;
            b.write(d.view.distance, rw);
            b.write(d.view.ids, rw);
        },
        [&cache = fc.cache, &cs, pipeline, atlasSampler, first, count, objectCount, objectsUniform,
         packedVoxels](const UpdateData& d, fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            setSdfScene(params, ctx, d.sdf, atlasSampler, objectsUniform);
            params.set("CacheJobs", ctx.buffer(d.jobs))
                .set("CacheObjectFlags", ctx.buffer(d.flags))
                .set("CacheObjectList", ctx.buffer(d.list))
                .set("CacheLevels", ctx.buffer(d.view.levels))
                .setStorage("cacheDistanceImage", ctx.texture(d.view.distance))
                .setStorage("cacheIdImage", ctx.texture(d.view.ids));
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            constexpr uint32_t kGroupVoxels = 8 * 8 * 8;  // the shader's workgroup
            const uint32_t groups =
                packedVoxels > 0 ? (packedVoxels + kGroupVoxels - 1) / kGroupVoxels : count;
            for (uint32_t done = 0; done < groups; done += kMaxGroupsPerDispatch) {
                const program::PushConstants push =
                    packedVoxels > 0
                        ? program::PushConstants{glm::uvec4(first, objectCount, count, packedVoxels),
                                                 glm::uvec4(done, 0u, 0u, 0u)}
                        : program::PushConstants{glm::uvec4(first + done, objectCount, 0u, 0u),
                                                 glm::uvec4(0u)};
                ctx.cmd.pushConstants(&push, sizeof(push));
                ctx.cmd.dispatch(std::min(kMaxGroupsPerDispatch, groups - done));
            }
        });
}

}  // namespace

void readSdfWorldCache(fg::PassBuilder& b, const SdfWorldCacheView& view) {
    b.read(view.distance, rhi::Access::ShaderSampled);
    b.read(view.ids, rhi::Access::ShaderSampled);
    b.read(view.levels, rhi::Access::UniformRead);  // the uniform block SdfCacheLevels
}

void setSdfWorldCache(ShaderParams& params, const fg::PassContext& ctx, const SdfWorldCacheView& view) {
    params.set("sdfCacheDistance", ctx.texture(view.distance), view.sampler)
        .set("sdfCacheIds", ctx.texture(view.ids), view.sampler)
        .set("SdfCacheLevels", ctx.buffer(view.levels));
}

SdfWorldCacheView sdfWorldCacheBinding(const Blackboard& board, bool& bound) {
    const SdfWorldCacheView* view = board.find<SdfWorldCacheView>();
    bound = view != nullptr;
    return bound ? *view : board.find<SdfWorldCacheStandIn>()->view;
}

namespace {
// The cache's pair of 3D textures (R32F distance, R32UI ids) of r x r x depth texels, named
// `cache.distance<suffix>` and `cache.ids<suffix>`.
void createTexturePair(rhi::Device& device, uint32_t r, uint32_t depth, rhi::TextureUsage usage,
                       const char* suffix, rhi::TextureHandle& distance, rhi::TextureHandle& ids) {
    rhi::TextureDesc d;
    d.dimension = rhi::TextureDimension::Tex3D;
    d.width = d.height = r;
    d.depthOrLayers = depth;
    d.usage = usage;
    d.format = rhi::Format::R32_FLOAT;
    d.debugName = fmt::format("cache.distance{}", suffix);
    distance = device.createTexture(d);
    d.format = rhi::Format::R32_UINT;
    d.debugName = fmt::format("cache.ids{}", suffix);
    ids = device.createTexture(d);
}
}  // namespace

SdfWorldCache::~SdfWorldCache() {
    for (rhi::TextureHandle t : {m_distance, m_ids, m_standInDistance, m_standInIds})
        if (t) m_device.destroy(t);
    if (m_standInLevels) m_device.destroy(m_standInLevels);
}

void SdfWorldCache::addStandIn(FrameContext& fc) {
    if (!m_standInLevels) {
        createTexturePair(m_device, 1, 1, rhi::TextureUsage::Sampled, "_stand_in", m_standInDistance,
                          m_standInIds);
        rhi::BufferDesc b;
        b.size = 16;
        b.usage = rhi::BufferUsage::Uniform | rhi::BufferUsage::CopyDst;
        b.debugName = "cache.levels_stand_in";
        m_standInLevels = m_device.createBuffer(b);
        const uint32_t zero[4] = {0u, 0u, 0u, 0u};  // a level count of 0: every lookup misses
        if (m_standInLevels) m_device.writeBuffer(m_standInLevels, 0, zero, sizeof(zero));
    }
    SdfWorldCacheStandIn& standIn = fc.board.add<SdfWorldCacheStandIn>();
    standIn.view.distance =
        fc.graph.importPersistent("cache.distance_stand_in", m_standInDistance, rhi::Access::ShaderSampled);
    standIn.view.ids =
        fc.graph.importPersistent("cache.ids_stand_in", m_standInIds, rhi::Access::ShaderSampled);
    standIn.view.levels =
        fc.graph.importPersistent("cache.levels_stand_in", m_standInLevels, rhi::Access::UniformRead);
    standIn.view.sampler = nearestSampler(fc.cache);
}

void SdfWorldCache::destroyTextures(fg::FrameGraph& graph) {
    for (rhi::TextureHandle* t : {&m_distance, &m_ids})
        if (*t) {
            graph.forgetPersistent(*t);
            m_device.destroy(*t);
            *t = {};
        }
    m_texLevels = m_texResolution = 0;
}

void SdfWorldCache::release(fg::FrameGraph& graph) {
    destroyTextures(graph);
    m_clipmap.reset();
    m_report = {};
}

bool SdfWorldCache::ensureTextures(fg::FrameGraph& graph, std::string& error) {
    const uint32_t r = m_clipmap.resolution(), levels = m_clipmap.levelCount();
    if (m_distance && m_texLevels == levels && m_texResolution == r) return true;
    destroyTextures(graph);
    createTexturePair(m_device, r, r * levels,
                      rhi::TextureUsage::Sampled | rhi::TextureUsage::Storage | rhi::TextureUsage::CopySrc,
                      "", m_distance, m_ids);
    if (!m_distance || !m_ids) {
        error = fmt::format("sdf world cache: creating two {}x{}x{} textures failed", r, r, r * levels);
        release(graph);
        return false;
    }
    m_texLevels = levels;
    m_texResolution = r;
    return true;
}

bool SdfWorldCache::add(FrameContext& fc, const SdfSceneData& scene, glm::vec3 camera,
                        const scene::AccelerationSettings& settings, std::string& error) {
    const std::vector<GpuSdfObject>& objects = scene.objects;
    m_objects.resize(objects.size());
    m_flags.assign(std::max<size_t>(objects.size(), 1), 0u);
    for (size_t i = 0; i < objects.size(); ++i)
        if (objects[i].info.x == uint32_t(SdfKind::Shapes) && exactProgram(scene.records, objects[i].info.y))
            m_flags[i] = kExactProgram;
    for (size_t i = 0; i < objects.size(); ++i)
        m_objects[i] = {objects[i].info.w, objects[i].model, glm::vec3(objects[i].boundsMin),
                        glm::vec3(objects[i].boundsMax)};
    const ClipmapSettings cs{settings.cacheLevels, settings.cacheResolution, settings.cacheVoxel,
                             settings.cacheBudgetVoxels};
    m_clipmap.update(cs, camera, m_objects);
    if (m_clipmap.layoutChanged() || !m_distance) {
        const bool hadTextures = m_distance.isValid();
        if (!ensureTextures(fc.graph, error)) return false;
        if (!hadTextures && !m_clipmap.layoutChanged()) {  // textures lost: fill everything again
            m_clipmap.reset();
            m_clipmap.update(cs, camera, m_objects);
        }
    }
    const uint32_t levels = m_clipmap.levelCount(), r = m_clipmap.resolution();
    m_levelsData.assign(16 + sizeof(CacheLevelGpu) * levels, 0);
    const uint32_t header[4] = {levels, r, 0u, 0u};
    std::memcpy(m_levelsData.data(), header, 16);
    std::memcpy(m_levelsData.data() + 16, m_clipmap.levels().data(), sizeof(CacheLevelGpu) * levels);

    const uint64_t texBytes = uint64_t(r) * r * r * levels * 4;
    SdfWorldCacheView& view = fc.board.add<SdfWorldCacheView>();
    view.distance = fc.graph.importPersistent("cache.distance", m_distance, rhi::Access::ShaderSampled);
    view.ids = fc.graph.importPersistent("cache.ids", m_ids, rhi::Access::ShaderSampled);
    view.levelCount = levels;
    view.bytes = 2 * texBytes;
    view.sampler = nearestSampler(fc.cache);
    UpdateData in;
    in.sdf = *fc.board.find<SdfSceneBuffers>();
    const WorldCacheClipmap& cm = m_clipmap;
    fc.graph.addPass<UpdateData>(
        "sdf_world_cache_upload", fg::PassKind::Transfer,
        [&](fg::PassBuilder& b, UpdateData& d) {
            uint64_t bytes = 0;
            d.view = view;
            d.view.levels = uploadBuffer(b, "cache.levels", m_levelsData.size(), bytes);
            d.jobs = uploadBuffer(b, "cache.jobs", pooledSize(cm.jobs().size() * sizeof(CacheJob)), bytes);
            d.list = uploadBuffer(b, "cache.list", pooledSize(cm.objectList().size() * 4), bytes);
            d.flags = uploadBuffer(b, "cache.flags", pooledSize(m_flags.size() * 4), bytes);
            view.levels = d.view.levels;
            view.bytes += m_levelsData.size();
            in.view = d.view;
            in.jobs = d.jobs;
            in.list = d.list;
            in.flags = d.flags;
        },
        [this](const UpdateData& d, fg::PassContext& ctx) {
            updateChunked(ctx.cmd, ctx.buffer(d.view.levels), m_levelsData.data(), m_levelsData.size());
            updateChunked(ctx.cmd, ctx.buffer(d.flags), m_flags.data(), m_flags.size() * 4);
            const auto& jobs = m_clipmap.jobs();
            const auto& list = m_clipmap.objectList();
            if (!jobs.empty())
                updateChunked(ctx.cmd, ctx.buffer(d.jobs), jobs.data(), jobs.size() * sizeof(CacheJob));
            if (!list.empty()) updateChunked(ctx.cmd, ctx.buffer(d.list), list.data(), list.size() * 4);
        });
    const uint32_t splats = cm.splatJobCount(), total = uint32_t(cm.jobs().size());
    const uint32_t objectCount = uint32_t(objects.size());
    const uint64_t splatVoxels = cm.stats().splatVoxels;  // at most the levels' voxels: fits 32 bits
    if (splats > 0)
        addUpdatePass(fc, "sdf_world_cache_splat", in, 0, splats, objectCount, uint32_t(splatVoxels));
    if (total > splats) addUpdatePass(fc, "sdf_world_cache", in, splats, total - splats, objectCount);

    m_report = {};
    m_report.active = true;
    m_report.levels = levels;
    m_report.resolution = r;
    m_report.voxel = cm.voxel(0);
    m_report.distanceBytes = m_report.idBytes = texBytes;
    m_report.voxels = cm.stats();
    m_report.jobs = total;
    return true;
}

bool SdfWorldCache::readBack(const fg::FrameGraph& graph, WorldCacheReadback& out, std::string& error) const {
    if (!m_report.active || !m_distance) {
        error = "sdf world cache: did not run in the last frame";
        return false;
    }
    std::vector<uint8_t> d, ids;
    if (!m_device.readTexture(m_distance, {}, graph.persistentState(m_distance), d) ||
        !m_device.readTexture(m_ids, {}, graph.persistentState(m_ids), ids)) {
        error = "sdf world cache: reading the textures back failed";
        return false;
    }
    out.resolution = m_clipmap.resolution();
    out.levels = m_clipmap.levelCount();
    out.levelInfo = m_clipmap.levels();
    out.distance.resize(d.size() / 4);
    std::memcpy(out.distance.data(), d.data(), out.distance.size() * 4);
    out.objectKeys.clear();
    for (const ClipmapObject& o : m_objects) out.objectKeys.push_back(o.key);
    out.ids.resize(ids.size() / 4);
    std::memcpy(out.ids.data(), ids.data(), out.ids.size() * 4);
    return true;
}

}  // namespace penumbra::render
