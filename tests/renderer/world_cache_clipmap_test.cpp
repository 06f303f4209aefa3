// CPU tests of the world SDF cache's clipmap manager (renderer/features/world_cache_clipmap.h): no
// GPU. Scrolling recomputes exactly the exposed slabs, changed objects queue exactly the bricks of
// their old and new regions, the budget drains the queue over frames without losing anything,
// moves below the slack mark nothing, and the region -> objects query returns exactly the
// overlapping objects plus every unbounded one. Each assertion states its metric next to it.
#include <algorithm>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "renderer/features/world_cache_clipmap.h"

namespace penumbra::render {
namespace {

ClipmapObject box(uint32_t key, glm::vec3 centre, float half = 0.5f) {
    ClipmapObject o;
    o.key = key;
    o.model = glm::translate(glm::mat4(1.0f), centre);
    o.localMin = glm::vec3(-half);
    o.localMax = glm::vec3(half);
    return o;
}
ClipmapObject plane(uint32_t key) {
    ClipmapObject o;
    o.key = key;
    o.localMin = {-1e30f, -1e30f, -1e30f};
    o.localMax = {1e30f, 0.0f, 1e30f};
    return o;
}

// Three levels needed: objects at x = +-10 with R = 32, h0 = 0.25 (level 2 spans 32 units).
std::vector<ClipmapObject> spreadScene() {
    return {box(1, {-10, 0, 0}), box(2, {0, 0, 0}), box(3, {10, 0, 0})};
}
ClipmapSettings settings(uint32_t budget = 1u << 20, uint32_t res = 32) { return {3, res, 0.25f, budget}; }

int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

using Boxes = std::vector<std::pair<glm::vec3, glm::vec3>>;
using BrickKey = std::tuple<uint32_t, int, int, int>;  // level, brick x, y, z

// Calls f(brick, p0, p1) for every brick of every level that one of the world boxes grown by T + s
// reaches, with [p0, p1) the grown box's voxels in that brick (clipped to the window).
template <typename F>
void forEachGrownBrick(const WorldCacheClipmap& c, const Boxes& boxes, F&& f) {
    for (uint32_t l = 0; l < c.levelCount(); ++l) {
        const float h = c.voxel(l), g = kCacheTruncationVoxels * h + c.slack(l);
        const glm::ivec3 wo = c.origin(l), w1 = wo + glm::ivec3(int(c.resolution()));
        for (const auto& [lo, hi] : boxes) {
            // As the clipmap rounds: the grown box in float, divided by h in double.
            glm::ivec3 a(glm::floor(glm::dvec3(lo - g) / double(h))),
                b(glm::floor(glm::dvec3(hi + g) / double(h)));
            a = glm::max(a, wo);
            b = glm::min(b, w1 - 1);  // inclusive
            for (int z = floorDiv(a.z, 8); z <= floorDiv(b.z, 8); ++z)
                for (int y = floorDiv(a.y, 8); y <= floorDiv(b.y, 8); ++y)
                    for (int x = floorDiv(a.x, 8); x <= floorDiv(b.x, 8); ++x) {
                        const glm::ivec3 brick(x, y, z);
                        f(BrickKey{l, x, y, z}, glm::max(a, brick * 8), glm::min(b + 1, brick * 8 + 8));
                    }
        }
    }
}

uint64_t boxVoxels(glm::ivec3 p0, glm::ivec3 p1) {
    const glm::ivec3 e = p1 - p0;
    return glm::all(glm::greaterThan(e, glm::ivec3(0))) ? uint64_t(e.x) * uint64_t(e.y) * uint64_t(e.z) : 0;
}

// The voxels of every brick (clipped to its window) within T + s of one of the world boxes.
uint64_t expectedBrickVoxels(const WorldCacheClipmap& c, const Boxes& boxes) {
    std::set<BrickKey> bricks;
    forEachGrownBrick(c, boxes, [&](const BrickKey& key, glm::ivec3, glm::ivec3) { bricks.insert(key); });
    uint64_t voxels = 0;
    for (const auto& [l, x, y, z] : bricks) {
        const glm::ivec3 wo = c.origin(l), w1 = wo + glm::ivec3(int(c.resolution()));
        voxels += boxVoxels(glm::max(glm::ivec3(x, y, z) * 8, wo), glm::min(glm::ivec3(x, y, z) * 8 + 8, w1));
    }
    return voxels;
}

// The voxels the splats of those boxes cover: in every such brick, the bounding box of the parts
// of the grown boxes that reach into it.
uint64_t expectedSplatVoxels(const WorldCacheClipmap& c, const Boxes& boxes) {
    std::map<BrickKey, std::pair<glm::ivec3, glm::ivec3>> parts;
    forEachGrownBrick(c, boxes, [&](const BrickKey& key, glm::ivec3 p0, glm::ivec3 p1) {
        auto [it, added] = parts.insert({key, {p0, p1}});
        if (!added) it->second = {glm::min(it->second.first, p0), glm::max(it->second.second, p1)};
    });
    uint64_t voxels = 0;
    for (const auto& [key, box] : parts) voxels += boxVoxels(box.first, box.second);
    return voxels;
}

TEST(WorldCacheClipmap, FirstFrameFillsEveryNeededLevel) {
    WorldCacheClipmap c;
    c.update(settings(), {0.1f, 0.1f, 0.1f}, spreadScene());
    EXPECT_TRUE(c.layoutChanged());
    EXPECT_EQ(c.levelCount(), 3u);  // level 2 (32 units) is the first whose window holds x = +-10.5
    EXPECT_EQ(c.stats().fullVoxels, 3ull * 32 * 32 * 32);  // every voxel of every level, once
    EXPECT_EQ(c.stats().scrollVoxels + c.stats().dirtyVoxels + c.stats().splatVoxels, 0u);
    // A one-object scene needs one level.
    WorldCacheClipmap one;
    one.update(settings(), {0.1f, 0.1f, 0.1f}, {box(1, {0, 0, 0})});
    EXPECT_EQ(one.levelCount(), 1u);
}

TEST(WorldCacheClipmap, ScrollRecomputesExactlyTheExposedSlabs) {
    WorldCacheClipmap c;
    const auto objects = spreadScene();
    c.update(settings(), {0.1f, 0.1f, 0.1f}, objects);
    // Within one level-0 voxel: nothing.
    c.update(settings(), {0.2f, 0.2f, 0.2f}, objects);
    EXPECT_EQ(c.stats().scrollVoxels, 0u);  // camera inside the same voxel of every level
    EXPECT_TRUE(c.jobs().empty());
    // +3 level-0 voxels in x (0.2 -> 0.95): level 0 scrolls 3, level 1 (h 0.5) 1, level 2 (h 1) 0.
    c.update(settings(), {0.95f, 0.2f, 0.2f}, objects);
    const uint64_t r2 = 32 * 32;
    std::printf("  scroll x +3 voxels: %llu voxels\n", (unsigned long long)c.stats().scrollVoxels);
    EXPECT_EQ(c.stats().scrollVoxels, (3 + 1) * r2);  // k * R * R per scrolled level and axis
    EXPECT_EQ(c.stats().fullVoxels + c.stats().dirtyVoxels, 0u);
    // -1 voxel in y and +2 in z at level 0 only (0.2 -> -0.05, 0.2 -> 0.7): unique voxels
    // R^3 - (R - 1)(R - 2) R at level 0; level 1 scrolls 1 in y (0 -> -1), 1 in z (0 -> 1).
    c.update(settings(), {0.95f, -0.05f, 0.7f}, objects);
    const uint64_t r = 32;
    const uint64_t level0 = r * r * r - (r - 1) * (r - 2) * r;
    const uint64_t level1 = r * r * r - (r - 1) * (r - 1) * r;
    const uint64_t level2 = r * r * r - (r - 1) * r * r;          // y: floor(-0.05) = -1
    EXPECT_EQ(c.stats().scrollVoxels, level0 + level1 + level2);  // disjoint slabs: no voxel twice
    // A jump of R voxels or more refills the level.
    c.update(settings(), {0.95f + 40.0f * 0.25f, -0.05f, 0.7f}, objects);
    EXPECT_GE(c.stats().fullVoxels, r * r * r);
}

TEST(WorldCacheClipmap, ChangedObjectsQueueOnlyTheirOldAndNewRegions) {
    WorldCacheClipmap c;
    auto objects = spreadScene();
    const glm::vec3 cam(0.1f);
    c.update(settings(1u << 20, 64), cam, objects);
    const glm::vec3 oldC(0, 0, 0), newC(1.0f, 0.5f, 0);
    objects[1] = box(2, newC);
    c.update(settings(1u << 20, 64), cam, objects);
    EXPECT_EQ(c.stats().changedObjects, 1u);
    const uint64_t expected =
        expectedBrickVoxels(c, {{oldC - 0.5f, oldC + 0.5f}, {newC - 0.5f, newC + 0.5f}});
    std::printf("  moved object: %llu dirty voxels (expected %llu), %llu splat voxels\n",
                (unsigned long long)c.stats().dirtyVoxels, (unsigned long long)expected,
                (unsigned long long)c.stats().splatVoxels);
    EXPECT_EQ(c.stats().dirtyVoxels, expected);  // exactly the bricks of old + new bounds (+ T + s)
    // The same bricks get the immediate splat, over the voxels within T + s of the boxes only.
    const uint64_t splat = expectedSplatVoxels(c, {{oldC - 0.5f, oldC + 0.5f}, {newC - 0.5f, newC + 0.5f}});
    std::printf("  splat voxels expected %llu\n", (unsigned long long)splat);
    EXPECT_EQ(c.stats().splatVoxels, splat);
    EXPECT_LT(splat, expected);  // the bricks' voxels beyond T + s are left out
    EXPECT_EQ(c.stats().scrollVoxels, 0u);
    EXPECT_LT(expected, uint64_t(c.levelCount()) * 64 * 64 * 64 / 4);  // a small part of the windows
    // Every splat job lists the moved object (index 1), and only it.
    // Their first voxels in the packed splat dispatch are the running sum of their boxes' voxels.
    uint64_t packed = 0;
    for (uint32_t j = 0; j < c.splatJobCount(); ++j) {
        const CacheJob& job = c.jobs()[j];
        ASSERT_EQ(job.list.y, 1u);
        EXPECT_EQ(c.objectList()[job.list.x], 1u);
        EXPECT_EQ(job.list.z, packed);
        packed += uint64_t(job.size.x) * job.size.y * job.size.z;
    }
    EXPECT_EQ(packed, splat);
    // A removed object queues its old region; an index change (the array reordered) is a move.
    objects.erase(objects.begin());  // key 1 removed; keys 2, 3 shift to indices 0, 1
    c.update(settings(1u << 20, 64), cam, objects);
    EXPECT_EQ(c.stats().changedObjects, 3u);
}

// Brick coordinates past 2^19 (1e5 units from the origin at 0.01-unit voxels): bricks are keyed
// by full 32-bit coordinates, so none is lost or merged.
TEST(WorldCacheClipmap, DirtyBricksFarFromTheOrigin) {
    WorldCacheClipmap c;
    const glm::vec3 base(1.0e5f, 0.0f, 0.0f);
    std::vector<ClipmapObject> objects{box(1, base, 0.05f)};
    const ClipmapSettings s{1, 64, 0.01f, 1u << 20};
    c.update(s, base, objects);
    const glm::vec3 moved = base + glm::vec3(0.1f, 0.0f, 0.0f);
    objects[0] = box(1, moved, 0.05f);
    c.update(s, base, objects);
    const uint64_t expected =
        expectedBrickVoxels(c, {{base - 0.05f, base + 0.05f}, {moved - 0.05f, moved + 0.05f}});
    EXPECT_EQ(c.stats().dirtyVoxels, expected);  // exactly the bricks of old + new bounds (+ T + s)
    EXPECT_GT(expected, 0u);
}

TEST(WorldCacheClipmap, SubSlackMovesMarkNothing) {
    WorldCacheClipmap c;
    auto objects = spreadScene();
    const glm::vec3 cam(0.1f);
    c.update(settings(), cam, objects);
    const float s = c.slack();
    objects[1] = box(2, {0.4f * s, 0, 0});
    c.update(settings(), cam, objects);
    EXPECT_EQ(c.stats().changedObjects, 0u);  // 0.4 s < s / 2: covered by the margin
    EXPECT_TRUE(c.jobs().empty());
    objects[1] = box(2, {0.8f * s, 0, 0});  // 0.8 s from the reference state, 0.4 s from the last frame
    c.update(settings(), cam, objects);
    EXPECT_EQ(c.stats().changedObjects, 1u);  // small moves accumulate against the last update
}

// The slack grows with the level's voxel (s_i = h_i / 4) and each level keeps its own reference
// state: a move past s_0 / 2 but within s_1 / 2 re-marks level 0 only; once the moves add up past
// s_1 / 2 (against level 1's reference) level 1 follows, level 2 (s_2 / 2 = 2 s_0) still not.
TEST(WorldCacheClipmap, CoarseLevelsFollowOnlyMovesBeyondTheirSlack) {
    WorldCacheClipmap c;
    auto objects = spreadScene();
    const glm::vec3 cam(0.1f);
    c.update(settings(), cam, objects);
    const float s0 = c.slack(0);
    EXPECT_FLOAT_EQ(c.slack(1), 2.0f * s0);  // s_i = h_i / 4
    auto levelsOfJobs = [&c] {
        std::set<int> levels;
        for (const CacheJob& j : c.jobs()) levels.insert(j.origin.w);
        return levels;
    };
    objects[1] = box(2, {0.75f * s0, 0, 0});  // 0.75 s0: past s0 / 2, within s1 / 2 = s0
    c.update(settings(), cam, objects);
    EXPECT_EQ(c.stats().changedObjects, 1u);
    EXPECT_EQ(levelsOfJobs(), std::set<int>({0}));  // jobs (splats and recomputes) on level 0 only
    objects[1] = box(2, {1.5f * s0, 0, 0});         // 1.5 s0 from level 1's reference, 0.75 s0 from level 0's
    c.update(settings(), cam, objects);
    EXPECT_EQ(c.stats().changedObjects, 1u);
    EXPECT_EQ(levelsOfJobs(), std::set<int>({0, 1}));  // level 2: 1.5 s0 < s2 / 2 = 2 s0
}

TEST(WorldCacheClipmap, BudgetDrainsTheQueueOverFramesLosingNothing) {
    WorldCacheClipmap c;
    auto objects = spreadScene();
    const glm::vec3 cam(0.1f);
    const uint32_t budget = 1000;  // about two bricks
    c.update(settings(budget, 64), cam, objects);
    for (auto& o : objects) o.model = glm::translate(o.model, glm::vec3(0.3f, 0.2f, -0.1f));
    c.update(settings(budget, 64), cam, objects);
    const uint64_t expected =
        expectedBrickVoxels(c, {{glm::vec3(-10.5f, -0.5f, -0.5f), glm::vec3(-9.5f, 0.5f, 0.5f)},
                                {glm::vec3(-0.5f), glm::vec3(0.5f)},
                                {glm::vec3(9.5f, -0.5f, -0.5f), glm::vec3(10.5f, 0.5f, 0.5f)},
                                {glm::vec3(-10.2f, -0.3f, -0.6f), glm::vec3(-9.2f, 0.7f, 0.4f)},
                                {glm::vec3(-0.2f, -0.3f, -0.6f), glm::vec3(0.8f, 0.7f, 0.4f)},
                                {glm::vec3(9.8f, -0.3f, -0.6f), glm::vec3(10.8f, 0.7f, 0.4f)}});
    uint64_t total = 0;
    int frames = 0;
    for (; frames < 10000; ++frames) {
        if (frames > 0) c.update(settings(budget, 64), cam, objects);
        EXPECT_LE(c.stats().dirtyVoxels, 512u + budget);  // within the budget (+ at most one brick)
        total += c.stats().dirtyVoxels;
        if (c.queuedBricks() == 0) break;
        EXPECT_GT(c.stats().dirtyVoxels, 0u);  // progress every frame
    }
    std::printf("  drained %llu voxels in %d frames (expected %llu)\n", (unsigned long long)total, frames + 1,
                (unsigned long long)expected);
    EXPECT_EQ(total, expected);  // every queued voxel recomputed exactly once
    EXPECT_EQ(c.stats().queuedVoxels, 0u);
    EXPECT_GT(frames, 5);  // the budget did spread the work
}

TEST(WorldCacheClipmap, RegionQueryReturnsExactlyTheOverlappingObjects) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-20.0f, 20.0f), size(0.05f, 3.0f);
    std::vector<ClipmapObject> objects;
    for (uint32_t i = 0; i < 300; ++i)
        objects.push_back(box(i + 1, {pos(rng), pos(rng), pos(rng)}, size(rng)));
    objects.push_back(plane(1000));
    objects.push_back(plane(1001));
    WorldCacheClipmap c;
    ClipmapSettings s{4, 32, 0.25f, 1u << 20};
    c.update(s, glm::vec3(0.0f), objects);
    std::vector<uint32_t> got;
    size_t checked = 0, hits = 0;
    for (int q = 0; q < 500; ++q) {
        const uint32_t level = uint32_t(q % int(c.levelCount()));
        const glm::vec3 lo(pos(rng), pos(rng), pos(rng));
        const glm::vec3 hi = lo + glm::vec3(8.0f * c.voxel(level));
        const float grow = 2.0f * c.voxel(level);
        c.objectsOverlapping(level, lo, hi, grow, got);
        std::vector<uint32_t> want;
        for (uint32_t i = 0; i < objects.size(); ++i) {
            const glm::vec3 ol = glm::vec3(objects[i].model[3]) + objects[i].localMin;
            const glm::vec3 oh = glm::vec3(objects[i].model[3]) + objects[i].localMax;
            const bool unbounded = i >= 300;
            if (unbounded ||
                (glm::all(glm::lessThanEqual(ol, hi + grow)) && glm::all(glm::lessThanEqual(lo - grow, oh))))
                want.push_back(i);
        }
        EXPECT_EQ(got, want) << "query " << q;  // exactly the overlapping objects + both planes
        ++checked;
        hits += want.size() - 2;
    }
    std::printf("  %zu queries, %zu bounded hits\n", checked, hits);
}

}  // namespace
}  // namespace penumbra::render
