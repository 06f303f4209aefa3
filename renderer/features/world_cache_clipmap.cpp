#include "renderer/features/world_cache_clipmap.h"

#include <algorithm>
#include <cmath>

namespace penumbra::render {
namespace {

constexpr float kUnboundedThreshold = 0.5e30f;  // renderer kSdfUnbounded / 2
constexpr uint64_t kMaxGridCellsPerObject = 512;
constexpr uint64_t kMaxGridCellsPerQuery = 4096;

CacheBrickKey brickKey(uint32_t level, glm::ivec3 b) { return {int32_t(level), b.x, b.y, b.z}; }
void unpackBrick(const CacheBrickKey& key, uint32_t& level, glm::ivec3& b) {
    level = uint32_t(key[0]);
    b = {key[1], key[2], key[3]};
}
uint64_t cellKey(glm::ivec3 c) {
    auto p = [](int v) { return uint64_t(uint32_t(v + (1 << 20)) & 0x1fffffu); };
    return (p(c.x) << 42) | (p(c.y) << 21) | p(c.z);
}

int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
int posMod(int a, int b) { return ((a % b) + b) % b; }
glm::ivec3 floorToVoxel(glm::vec3 p, float h) {
    auto f = [h](float v) { return int(std::clamp(std::floor(double(v) / double(h)), -1.0e9, 1.0e9)); };
    return {f(p.x), f(p.y), f(p.z)};
}

CacheBox intersect(const CacheBox& a, const CacheBox& b) {
    return {glm::max(a.min, b.min), glm::min(a.max, b.max)};
}

bool unboundedBox(const ClipmapObject& o) {
    const glm::vec3 m = glm::max(glm::abs(o.localMin), glm::abs(o.localMax));
    return std::max({m.x, m.y, m.z}) >= kUnboundedThreshold;
}

std::array<glm::vec3, 8> worldCorners(const ClipmapObject& o) {
    std::array<glm::vec3, 8> c{};
    for (int i = 0; i < 8; ++i) {
        const glm::vec3 l((i & 1) ? o.localMax.x : o.localMin.x, (i & 2) ? o.localMax.y : o.localMin.y,
                          (i & 4) ? o.localMax.z : o.localMin.z);
        c[size_t(i)] = glm::vec3(o.model * glm::vec4(l, 1.0f));
    }
    return c;
}

}  // namespace

uint64_t CacheBox::voxels() const {
    if (empty()) return 0;
    const glm::ivec3 e = max - min;
    return uint64_t(e.x) * uint64_t(e.y) * uint64_t(e.z);
}
bool CacheBox::empty() const { return max.x <= min.x || max.y <= min.y || max.z <= min.z; }

void WorldCacheClipmap::reset() {
    m_valid = false;
    m_levelCount = 0;
    m_tracked.clear();
    m_queue.clear();
    m_queued.clear();
}

CacheBox WorldCacheClipmap::window(uint32_t level) const {
    const glm::ivec3 o = m_origin[level];
    return {o, o + glm::ivec3(int(m_resolution))};
}

CacheBox WorldCacheClipmap::brickBox(uint32_t level, glm::ivec3 brick) const {
    const int b = int(kCacheBrick);
    return intersect({brick * b, brick * b + glm::ivec3(b)}, window(level));
}

void WorldCacheClipmap::update(const ClipmapSettings& settings, glm::vec3 camera,
                               const std::vector<ClipmapObject>& objects) {
    m_jobs.clear();
    m_list.clear();
    m_splatJobs = 0;
    m_stats = {};
    m_layoutChanged = false;
    const size_t n = objects.size();
    m_lo.assign(n, glm::vec3(0.0f));
    m_hi.assign(n, glm::vec3(0.0f));
    m_unbounded.assign(n, false);
    m_unboundedList.clear();
    for (size_t i = 0; i < n; ++i) {
        if (unboundedBox(objects[i])) {
            m_unbounded[i] = true;
            m_unboundedList.push_back(uint32_t(i));
            continue;
        }
        const auto c = worldCorners(objects[i]);
        m_lo[i] = m_hi[i] = c[0];
        for (const glm::vec3& p : c) {
            m_lo[i] = glm::min(m_lo[i], p);
            m_hi[i] = glm::max(m_hi[i], p);
        }
    }
    m_stamp.assign(n, 0);
    m_stampValue = 0;

    const std::vector<glm::ivec3> oldOrigin = m_origin;
    chooseLayout(settings, camera);
    buildGrids();
    if (!m_valid) {
        m_tracked.clear();
        planChanges(objects);  // records every object; its splats and queue are dropped (all recomputed)
        m_jobs.clear();
        m_list.clear();
        m_splatJobs = 0;
        m_stats = {};
        m_queue.clear();
        m_queued.clear();
        for (uint32_t l = 0; l < m_levelCount; ++l)
            addBoxJobs(l, window(l), CacheJobMode::Recompute, m_stats.fullVoxels);
        m_valid = true;
    } else {
        planChanges(objects);
        planScroll(oldOrigin);
        drainQueue(std::max(settings.budgetVoxels, 1u));
    }
    for (const CacheBrickKey& key : m_queue) {
        uint32_t level;
        glm::ivec3 b;
        unpackBrick(key, level, b);
        m_stats.queuedVoxels += level < m_levelCount ? brickBox(level, b).voxels() : 0;
    }
    fillLevelsGpu();
}

// Resolution, h_0 and the level count; invalidates the cache when any of them changes (the level
// count only grows while the layout lives). Then the camera-centred, snapped window origins.
void WorldCacheClipmap::chooseLayout(const ClipmapSettings& s, glm::vec3 camera) {
    const uint32_t res = std::max(kCacheBrick, s.resolution / kCacheBrick * kCacheBrick);
    const uint32_t maxLevels = std::clamp(s.levels, 1u, kMaxCacheLevels);
    std::vector<float> extents;
    glm::vec3 lo(1e30f), hi(-1e30f);
    for (size_t i = 0; i < m_lo.size(); ++i) {
        if (m_unbounded[i]) continue;
        const glm::vec3 e = m_hi[i] - m_lo[i];
        extents.push_back(std::max({e.x, e.y, e.z}));
        lo = glm::min(lo, m_lo[i]);
        hi = glm::max(hi, m_hi[i]);
    }
    float h0 = s.voxel;
    if (!(h0 > 0.0f) || !std::isfinite(h0)) {
        float median = 1.0f;
        if (!extents.empty()) {
            std::nth_element(extents.begin(), extents.begin() + extents.size() / 2, extents.end());
            median = std::max(extents[extents.size() / 2], 1e-3f);
        }
        h0 = std::exp2(std::floor(std::log2(median / 8.0f)));
    }
    uint32_t needed = extents.empty() ? maxLevels : 1;
    while (!extents.empty() && needed < maxLevels) {  // the coarsest window must hold every object
        const float h = h0 * float(1u << (needed - 1));
        const glm::ivec3 o = floorToVoxel(camera, h) - glm::ivec3(int(res / 2));
        const glm::ivec3 a = floorToVoxel(lo, h), b = floorToVoxel(hi, h);
        if (glm::all(glm::greaterThanEqual(a, o)) && glm::all(glm::lessThan(b, o + glm::ivec3(int(res)))))
            break;
        ++needed;
    }
    const bool sameBase = m_valid && res == m_resolution && h0 == m_voxel0 && maxLevels == m_maxLevels;
    if (!sameBase || needed > m_levelCount) {
        m_valid = false;
        m_layoutChanged = true;
        m_resolution = res;
        m_voxel0 = h0;
        m_maxLevels = maxLevels;
        m_levelCount = sameBase ? std::max(needed, m_levelCount) : needed;
    }
    m_origin.resize(m_levelCount);
    for (uint32_t l = 0; l < m_levelCount; ++l)
        m_origin[l] = floorToVoxel(camera, voxel(l)) - glm::ivec3(int(m_resolution / 2));
}

// One uniform grid of bounded object boxes per level, cells of 16 h_i: a brick grown by the
// truncation spans at most 3 cells per axis.
void WorldCacheClipmap::buildGrids() {
    m_grids.assign(m_levelCount, Grid{});
    for (uint32_t l = 0; l < m_levelCount; ++l) {
        Grid& g = m_grids[l];
        g.cell = 16.0f * voxel(l);
        for (uint32_t i = 0; i < m_lo.size(); ++i) {
            if (m_unbounded[i]) continue;
            const glm::ivec3 a = floorToVoxel(m_lo[i], g.cell), b = floorToVoxel(m_hi[i], g.cell);
            const glm::ivec3 e = b - a + 1;
            if (uint64_t(e.x) * uint64_t(e.y) * uint64_t(e.z) > kMaxGridCellsPerObject) {
                g.large.push_back(i);
                continue;
            }
            for (int z = a.z; z <= b.z; ++z)
                for (int y = a.y; y <= b.y; ++y)
                    for (int x = a.x; x <= b.x; ++x) g.cells[cellKey({x, y, z})].push_back(i);
        }
    }
}

void WorldCacheClipmap::objectsOverlapping(uint32_t level, glm::vec3 lo, glm::vec3 hi, float grow,
                                           std::vector<uint32_t>& out) {
    out.clear();
    if (level >= m_grids.size()) return;
    const Grid& g = m_grids[level];
    lo -= glm::vec3(grow);
    hi += glm::vec3(grow);
    ++m_stampValue;
    auto consider = [&](uint32_t i) {
        if (m_stamp[i] == m_stampValue) return;
        m_stamp[i] = m_stampValue;
        if (glm::all(glm::lessThanEqual(m_lo[i], hi)) && glm::all(glm::lessThanEqual(lo, m_hi[i])))
            out.push_back(i);
    };
    const glm::ivec3 a = floorToVoxel(lo, g.cell), b = floorToVoxel(hi, g.cell);
    const glm::ivec3 e = b - a + 1;
    if (uint64_t(e.x) * uint64_t(e.y) * uint64_t(e.z) > kMaxGridCellsPerQuery) {
        for (uint32_t i = 0; i < m_lo.size(); ++i)  // a query larger than the grid is worth
            if (!m_unbounded[i]) consider(i);
    } else {
        for (int z = a.z; z <= b.z; ++z)
            for (int y = a.y; y <= b.y; ++y)
                for (int x = a.x; x <= b.x; ++x) {
                    auto it = g.cells.find(cellKey({x, y, z}));
                    if (it != g.cells.end())
                        for (uint32_t i : it->second) consider(i);
                }
        for (uint32_t i : g.large) consider(i);
    }
    out.insert(out.end(), m_unboundedList.begin(), m_unboundedList.end());
    std::sort(out.begin(), out.end());
}

// A recompute job lists its objects nearest first (by the distance from the box centre to their
// world boxes; unbounded ones first): the shader skips an object whose box distance is at least
// the second-nearest value so far, so near objects first shrink that value early and most far
// ones are skipped without evaluating them. The result does not depend on the order (a tie leaves
// the cell UNCERTAIN either way), only the work does.
void WorldCacheClipmap::addJob(uint32_t level, const CacheBox& box, CacheJobMode mode,
                               const std::vector<uint32_t>& objects) {
    CacheJob j;
    j.origin = glm::ivec4(box.min, int(level));
    j.size = glm::uvec4(glm::uvec3(box.max - box.min), uint32_t(mode));
    j.list = glm::uvec4(uint32_t(m_list.size()), uint32_t(objects.size()), 0u, 0u);
    const size_t first = m_list.size();
    m_list.insert(m_list.end(), objects.begin(), objects.end());
    if (mode == CacheJobMode::Recompute && objects.size() > 2) {
        const glm::vec3 c = glm::vec3(box.min + box.max) * (0.5f * voxel(level));
        auto key = [&](uint32_t i) {
            if (i >= m_lo.size() || m_unbounded[i]) return -1.0f;
            const glm::vec3 d = glm::max(glm::max(m_lo[i] - c, c - m_hi[i]), glm::vec3(0.0f));
            return glm::dot(d, d);
        };
        std::stable_sort(m_list.begin() + std::ptrdiff_t(first), m_list.end(),
                         [&](uint32_t a, uint32_t b) { return key(a) < key(b); });
    }
    m_jobs.push_back(j);
}

// Splits a voxel box of one level at the brick grid; each piece is recomputed against the objects
// within T + s of it.
void WorldCacheClipmap::addBoxJobs(uint32_t level, const CacheBox& box, CacheJobMode mode,
                                   uint64_t& counter) {
    if (box.empty()) return;
    const int b = int(kCacheBrick);
    const float h = voxel(level), grow = kCacheTruncationVoxels * h + slack(level);
    std::vector<uint32_t> objs;
    const glm::ivec3 b0(floorDiv(box.min.x, b), floorDiv(box.min.y, b), floorDiv(box.min.z, b));
    const glm::ivec3 b1(floorDiv(box.max.x - 1, b), floorDiv(box.max.y - 1, b), floorDiv(box.max.z - 1, b));
    for (int z = b0.z; z <= b1.z; ++z)
        for (int y = b0.y; y <= b1.y; ++y)
            for (int x = b0.x; x <= b1.x; ++x) {
                const glm::ivec3 brick(x, y, z);
                const CacheBox piece = intersect({brick * b, brick * b + glm::ivec3(b)}, box);
                if (piece.empty()) continue;
                objectsOverlapping(level, glm::vec3(piece.min) * h, glm::vec3(piece.max) * h, grow, objs);
                addJob(level, piece, mode, objs);
                counter += piece.voxels();
            }
}

// The slabs each level's window scrolled in since the last frame, as disjoint boxes: x slab over
// the whole new window, y slab within the x overlap, z slab within the x and y overlap.
void WorldCacheClipmap::planScroll(const std::vector<glm::ivec3>& oldOrigin) {
    const int r = int(m_resolution);
    for (uint32_t l = 0; l < m_levelCount; ++l) {
        const glm::ivec3 o = oldOrigin[l], n = m_origin[l], d = n - o;
        if (glm::any(glm::greaterThanEqual(glm::abs(d), glm::ivec3(r)))) {
            addBoxJobs(l, window(l), CacheJobMode::Recompute, m_stats.fullVoxels);
            continue;
        }
        CacheBox rest = window(l);  // the part not yet assigned to a slab
        for (int a = 0; a < 3; ++a) {
            if (d[a] == 0) continue;
            CacheBox slab = rest;
            if (d[a] > 0) {
                slab.min[a] = o[a] + r;
                rest.max[a] = o[a] + r;
            } else {
                slab.max[a] = o[a];
                rest.min[a] = o[a];
            }
            addBoxJobs(l, slab, CacheJobMode::Recompute, m_stats.scrollVoxels);
        }
    }
}

// Compares every object with its per-level reference states; on each level it moved for (every
// level when it is new, re-indexed or reshaped) its old and new regions are queued and splatted,
// and the level's reference becomes the current state. Removed objects queue their old regions.
void WorldCacheClipmap::planChanges(const std::vector<ClipmapObject>& objects) {
    Splats splats;
    std::unordered_map<uint32_t, Tracked> now;
    now.reserve(objects.size());
    for (uint32_t i = 0; i < objects.size(); ++i) {
        const ClipmapObject& o = objects[i];
        auto it = m_tracked.find(o.key);
        const Tracked* old = it == m_tracked.end() ? nullptr : &it->second;
        const bool all = !old || old->index != i || old->unbounded != m_unbounded[i] ||
                         old->localMin != o.localMin || old->localMax != o.localMax;
        Tracked t;
        t.index = i;
        t.unbounded = m_unbounded[i];
        t.localMin = o.localMin;
        t.localMax = o.localMax;
        t.reference = old ? old->reference : std::vector<glm::mat4>{};
        t.reference.resize(m_levelCount, o.model);
        std::array<glm::vec3, 8> corners{};
        if (!t.unbounded) corners = worldCorners(o);
        bool any = false;
        for (uint32_t l = 0; l < m_levelCount; ++l) {
            const bool hadLevel = old && l < old->reference.size();
            bool changed = all || !hadLevel;
            if (!changed && old->reference[l] != o.model) {
                if (t.unbounded) {
                    changed = true;
                } else {  // a corner moved more than s_l / 2 from the level's reference
                    const auto ref = worldCorners({o.key, old->reference[l], o.localMin, o.localMax});
                    for (int c = 0; !changed && c < 8; ++c)
                        changed = glm::length(corners[size_t(c)] - ref[size_t(c)]) > 0.5f * slack(l);
                }
            }
            if (!changed) continue;  // small moves accumulate against the level's reference
            any = true;
            if (hadLevel) markOldRegion(l, *old, o.key, i, splats);
            markRegion(l, m_lo[i], m_hi[i], t.unbounded, i, splats);
            t.reference[l] = o.model;
        }
        if (any) ++m_stats.changedObjects;
        now[o.key] = std::move(t);
    }
    for (const auto& [key, t] : m_tracked)
        if (!now.count(key)) {
            ++m_stats.changedObjects;
            for (uint32_t l = 0; l < m_levelCount && l < t.reference.size(); ++l)
                markOldRegion(l, t, key, kCacheNone, splats);
        }
    m_tracked = std::move(now);
    for (auto& [key, splat] : splats) {
        std::vector<uint32_t>& objs = splat.objects;
        std::sort(objs.begin(), objs.end());
        objs.erase(std::unique(objs.begin(), objs.end()), objs.end());
        uint32_t level;
        glm::ivec3 b;
        unpackBrick(key, level, b);
        addJob(level, splat.box, CacheJobMode::Splat, objs);
        m_jobs.back().list.z = uint32_t(m_stats.splatVoxels);  // its first voxel in the packed dispatch
        m_stats.splatVoxels += splat.box.voxels();
        ++m_splatJobs;
    }
}

// Queues the region of a tracked object's reference state on one level.
void WorldCacheClipmap::markOldRegion(uint32_t level, const Tracked& t, uint32_t key, uint32_t splatObject,
                                      Splats& splats) {
    glm::vec3 lo(0.0f), hi(0.0f);
    if (!t.unbounded) {
        const auto c = worldCorners({key, t.reference[level], t.localMin, t.localMax});
        lo = hi = c[0];
        for (const glm::vec3& p : c) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
    }
    markRegion(level, lo, hi, t.unbounded, splatObject, splats);
}

// Queues the bricks of one level within T + s of the world box [lo, hi] (every brick of the
// window when `everywhere`), and lists `splatObject` (kCacheNone: none) for their splat, which
// covers the region's voxels in the brick only: a voxel whose cell lies farther than T + s from
// the object's box (before and after the change) keeps its value and id (the object's truncated
// distance there is T either way), so the splat's min and id reset would change nothing there.
void WorldCacheClipmap::markRegion(uint32_t l, glm::vec3 lo, glm::vec3 hi, bool everywhere,
                                   uint32_t splatObject, Splats& splats) {
    const int b = int(kCacheBrick);
    const float h = voxel(l), grow = kCacheTruncationVoxels * h + slack(l);
    CacheBox region = window(l);
    if (!everywhere)
        region = intersect(region, {floorToVoxel(lo - glm::vec3(grow), h),
                                    floorToVoxel(hi + glm::vec3(grow), h) + glm::ivec3(1)});
    if (region.empty()) return;
    const glm::ivec3 b0(floorDiv(region.min.x, b), floorDiv(region.min.y, b), floorDiv(region.min.z, b));
    const glm::ivec3 b1(floorDiv(region.max.x - 1, b), floorDiv(region.max.y - 1, b),
                        floorDiv(region.max.z - 1, b));
    for (int z = b0.z; z <= b1.z; ++z)
        for (int y = b0.y; y <= b1.y; ++y)
            for (int x = b0.x; x <= b1.x; ++x) {
                const CacheBrickKey key = brickKey(l, {x, y, z});
                if (m_queued.insert(key).second) m_queue.push_back(key);
                const CacheBox part = intersect(brickBox(l, {x, y, z}), region);
                Splat& s = splats[key];
                s.box = s.box.empty()
                            ? part
                            : CacheBox{glm::min(s.box.min, part.min), glm::max(s.box.max, part.max)};
                if (splatObject != kCacheNone) s.objects.push_back(splatObject);
            }
}

// Recomputes queued bricks (their part inside the current windows) up to `budget` voxels; at
// least one brick per frame, so a budget below a brick still drains.
void WorldCacheClipmap::drainQueue(uint32_t budget) {
    uint64_t done = 0;
    std::vector<uint32_t> objs;
    while (!m_queue.empty()) {
        const CacheBrickKey key = m_queue.front();
        uint32_t level;
        glm::ivec3 b;
        unpackBrick(key, level, b);
        const CacheBox box = level < m_levelCount ? brickBox(level, b) : CacheBox{};
        const uint64_t v = box.voxels();
        if (v > 0 && done > 0 && done + v > budget) break;
        m_queue.pop_front();
        m_queued.erase(key);
        if (v == 0) continue;  // scrolled out: recomputed when it scrolls back in
        const float h = voxel(level);
        objectsOverlapping(level, glm::vec3(box.min) * h, glm::vec3(box.max) * h,
                           kCacheTruncationVoxels * h + slack(level), objs);
        addJob(level, box, CacheJobMode::Recompute, objs);
        done += v;
        m_stats.dirtyVoxels += v;
    }
}

void WorldCacheClipmap::fillLevelsGpu() {
    m_levelsGpu.resize(m_levelCount);
    const int r = int(m_resolution);
    for (uint32_t l = 0; l < m_levelCount; ++l) {
        const float h = voxel(l);
        CacheLevelGpu& g = m_levelsGpu[l];
        g.origin = glm::ivec4(m_origin[l], int(l) * r);
        g.wrap = glm::ivec4(posMod(m_origin[l].x, r), posMod(m_origin[l].y, r), posMod(m_origin[l].z, r), 0);
        g.params = glm::vec4(h, kCacheTruncationVoxels * h, 0.8660255f * h + slack(l), slack(l));
    }
}

}  // namespace penumbra::render
