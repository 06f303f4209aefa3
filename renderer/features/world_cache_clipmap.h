// The CPU side of the world SDF cache (issue 13 items 1 and 2; renderer/features/sdf_world_cache.h
// is the GPU module): the clipmap layout, the scrolling windows, per-object change tracking, the
// dirty-brick queue under a per-frame voxel budget and the region -> objects query. No RHI: it turns
// one frame's objects and camera into a list of GPU jobs (CacheJob) and the levels table, and is
// tested alone (tests/renderer/world_cache_clipmap_test.cpp).
//
// Layout (after Wright's "Global SDF" clipmaps, reference 001, and mTec 8.2.2, reference 000):
//   L levels of R^3 voxels; level i has voxel h_i = h_0 * 2^i. h_0 is AccelerationSettings::
//   cacheVoxel, or, when 0, the power of two nearest below 1/8 of the median bounded object's
//   extent (so an object spans about 8 level-0 voxels). Only as many levels are used as it takes
//   for the camera-centred window of the coarsest one to hold every bounded object (at most
//   cacheLevels; the count only grows while the layout lives, so camera moves do not reallocate).
//   Each level is a window of R voxels per axis, origin floor(camera / h_i) - R/2 (snapped to its
//   voxel grid). Storage is toroidal: world voxel v of level i lives at texel (v mod R) + (0,0,i R)
//   of R x R x (R L) textures, so a camera move of k voxels recomputes only the k x R x R slab per
//   axis that scrolled in (in the same frame: those texels hold another place until then).
//
// Values (conservative; the GPU pass writes them): voxel v with centre c
//   D(v)  = min(T_i, min over objects d_obj(c)) - margin_i,  margin_i = sqrt(3)/2 h_i + s_i
//   id(v) = the nearest object when d_2 - U_1 >= sqrt(3) h_i + 2 s_i (d_2 the second-nearest value,
//           at most T_i; U_1 an upper bound of the nearest's true distance at c), UNCERTAIN
//           otherwise or when no upper bound is known, NONE when no object is within T_i
// with T_i = 8 h_i the truncation, s_i = h_i / 4 the level's motion slack, d_obj the conservative
// sdfObjectDistance (raised outside the object's bounds box to the box distance). For p in the
// cell |p - c| <= sqrt(3)/2 h_i, so the true distance at p >= D(v) as long as no object moved more
// than s_i since the value was computed; the id rule is the certain version of mTec's "neighbouring
// cells disagree" rule: the nearest object's true distance gains at most sqrt(3)/2 h + s_i and every
// other's loses at most as much anywhere in the cell, so the named object is the nearest
// everywhere in it. U_1 (sdf_world_cache_update.comp): exact shape programs (shapes, unions,
// transforms) under any scale (sigma_max / sigma_min times the value outside); fields where c lies
// in their box of voxel centres (interpolant + interpolation bound + the margin by which the
// interpolant may exceed the mesh distance: an upper bound of the mesh distance and of what the
// trace steps on the field); smooth or subtractive CSG and repetition have none (their cells stay
// UNCERTAIN). A field's d_obj is also a lower bound of the distance to its interpolated surface
// (sdfFieldRootDistance), the one the trace hits, which may lie nearer than its mesh.
//
// Changes: per object (keyed by entity index) and per level the model matrix at its last update of
// that level is kept (the reference). It moved for level i when a world box corner moved more than
// s_i / 2 since then: two values computed at states within s_i / 2 of that reference differ by at
// most s_i, which the level's margin covers, so smaller moves need no update of that level. The
// slack grows with the voxel, so a small per-frame move re-marks only the fine levels (a coarse
// level, whose bricks list the most objects, follows once the move adds up to its s_i / 2). A
// moved object queues the bricks (8^3 voxels) of its old (reference) and new world box grown by
// T_i + s_i on each level it moved for; an added or removed object (or one whose index in the
// frame's object array changed: ids are indices) on every level. Each queued brick gets an
// immediate min-splat this frame (D = min(D, d_new - margin_i), id = UNCERTAIN unless NONE stays
// true) so the cache is conservative before the queue reaches it, over the brick's voxels within
// T_i + s_i of the boxes that marked it (their bounding box in the brick): farther from both the
// old and the new box the object's truncated distance is T_i before and after, so a voxel there
// keeps a valid value and id. Queued bricks are recomputed
// against only the objects whose grown box overlaps them (a uniform grid per level), at most
// budgetVoxels per frame (at least one brick), the rest stays queued. Unbounded objects (planes)
// take part everywhere; one that changes dirties every level.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <set>
#include <unordered_map>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace penumbra::render {

inline constexpr uint32_t kCacheBrick = 8;                // voxels per brick side (one workgroup)
inline constexpr float kCacheTruncationVoxels = 8.0f;     // T_i = 8 h_i
inline constexpr float kCacheSlackVoxels = 0.25f;         // s_i = h_i / 4
inline constexpr uint32_t kCacheNone = 0xffffffffu;       // id: no object within T_i
inline constexpr uint32_t kCacheUncertain = 0xfffffffeu;  // id: the nearest object is not certain

// One object of the frame as the cache sees it.
struct ClipmapObject {
    uint32_t key = 0;  // stable identity across frames (entity index)
    glm::mat4 model{1.0f};
    glm::vec3 localMin{0.0f}, localMax{0.0f};  // local bounds of the solid (+-1e30: unbounded)
};

struct ClipmapSettings {
    uint32_t levels = 4;
    uint32_t resolution = 64;      // rounded down to a multiple of 8 (at least 8)
    float voxel = 0.0f;            // h_0; 0: from the scene
    uint32_t budgetVoxels = 2048;  // scene::AccelerationSettings::cacheBudgetVoxels
};

enum class CacheJobMode : uint32_t { Recompute = 0, Splat = 1 };

// One GPU job (48 bytes, std430): a box of at most 8^3 voxels of one level, and its objects.
struct CacheJob {
    glm::ivec4 origin;  // xyz first voxel (world voxel coordinates of the level), w level
    glm::uvec4 size;    // xyz voxels per axis (1..8), w CacheJobMode
    glm::uvec4 list;    // x first index into the object list, y count
};
static_assert(sizeof(CacheJob) == 48);

// The most clipmap levels a cache has (the shaders' level table holds 16).
inline constexpr uint32_t kMaxCacheLevels = 15;

// One level as the shaders see it (48 bytes, std140 and std430; renderer/shaders/sdf_world_cache.glsl).
struct CacheLevelGpu {
    glm::ivec4 origin;  // xyz window origin in voxels, w first z texel of the level (level * R)
    glm::ivec4 wrap;    // xyz origin mod R (0..R-1): texel of the origin voxel
    glm::vec4 params;   // x voxel size, y truncation T, z margin sqrt(3)/2 h + s, w slack s
};
static_assert(sizeof(CacheLevelGpu) == 48);

// Voxels the GPU recomputes this frame, by cause.
struct ClipmapFrameStats {
    uint64_t fullVoxels = 0;    // whole levels (new layout, a jump of R voxels or more)
    uint64_t scrollVoxels = 0;  // slabs scrolled in
    uint64_t dirtyVoxels = 0;   // queued bricks recomputed (within the budget)
    uint64_t splatVoxels = 0;   // immediate min-splats of changed objects
    uint64_t queuedVoxels = 0;  // still queued after this frame (upper bound: whole bricks)
    uint32_t changedObjects = 0;
};

// The cache's frame statistics (FrameStats::worldCache, penumbra --stats).
struct WorldCacheReport {
    bool active = false;
    uint32_t levels = 0, resolution = 0;
    float voxel = 0.0f;          // h_0
    uint64_t distanceBytes = 0;  // R32F texture
    uint64_t idBytes = 0;        // R32UI texture
    ClipmapFrameStats voxels;    // recomputed this frame by cause, and still queued
    uint32_t jobs = 0;
};

// The whole cache contents read back (tests): R x R x (R L) texels each.
struct WorldCacheReadback {
    uint32_t resolution = 0, levels = 0;
    std::vector<CacheLevelGpu> levelInfo;
    std::vector<float> distance;
    std::vector<uint32_t> ids;
    std::vector<uint32_t> objectKeys;  // per object index of the frame: its key (entity index)
};

using CacheBrickKey = std::array<int32_t, 4>;  // level, brick x, y, z (world voxel / 8)

struct CacheBox {
    glm::ivec3 min{0}, max{0};  // voxels [min, max)
    uint64_t voxels() const;
    bool empty() const;
};

class WorldCacheClipmap {
public:
    // Plans one frame: layout, scroll slabs, change tracking, splats and the budgeted queue.
    // Afterwards jobs() / objectList() / levels() hold what the GPU must do and see.
    void update(const ClipmapSettings& settings, glm::vec3 camera, const std::vector<ClipmapObject>& objects);
    // Forgets everything (the GPU contents are gone): the next update fills every level.
    void reset();

    bool layoutChanged() const { return m_layoutChanged; }  // this frame: reallocate and fill
    uint32_t levelCount() const { return m_levelCount; }
    uint32_t resolution() const { return m_resolution; }
    float voxel(uint32_t level) const { return m_voxel0 * float(1u << level); }
    float slack(uint32_t level = 0) const { return kCacheSlackVoxels * voxel(level); }  // s_i
    glm::ivec3 origin(uint32_t level) const { return m_origin[level]; }
    const std::vector<CacheLevelGpu>& levels() const { return m_levelsGpu; }
    const std::vector<CacheJob>& jobs() const { return m_jobs; }  // splats first, then recomputes
    uint32_t splatJobCount() const { return m_splatJobs; }
    const std::vector<uint32_t>& objectList() const { return m_list; }
    const ClipmapFrameStats& stats() const { return m_stats; }
    size_t queuedBricks() const { return m_queue.size(); }

    // Objects of the last update() whose world box grown by `grow` overlaps the world box
    // [lo, hi], ascending, plus every unbounded one; from the level's uniform grid.
    void objectsOverlapping(uint32_t level, glm::vec3 lo, glm::vec3 hi, float grow,
                            std::vector<uint32_t>& out);

private:
    struct Tracked {
        uint32_t index = 0;
        bool unbounded = false;
        glm::vec3 localMin{0.0f}, localMax{0.0f};
        std::vector<glm::mat4> reference;  // per level: the model at that level's last update
    };
    struct Grid {
        float cell = 1.0f;
        std::unordered_map<uint64_t, std::vector<uint32_t>> cells;
        std::vector<uint32_t> large;  // bounded objects spanning too many cells: always tested
    };

    void chooseLayout(const ClipmapSettings& s, glm::vec3 camera);
    void buildGrids();
    void planScroll(const std::vector<glm::ivec3>& oldOrigin);
    void planChanges(const std::vector<ClipmapObject>& objects);
    // One brick's splat: the objects it takes, and the voxels it covers (the bounding box of the
    // marked regions' parts in the brick).
    struct Splat {
        std::vector<uint32_t> objects;
        CacheBox box;
    };
    using Splats = std::map<CacheBrickKey, Splat>;  // ordered: deterministic job order
    void markOldRegion(uint32_t level, const Tracked& t, uint32_t key, uint32_t splatObject, Splats& splats);
    void markRegion(uint32_t level, glm::vec3 lo, glm::vec3 hi, bool everywhere, uint32_t splatObject,
                    Splats& splats);
    void drainQueue(uint32_t budget);
    void addBoxJobs(uint32_t level, const CacheBox& box, CacheJobMode mode, uint64_t& counter);
    void addJob(uint32_t level, const CacheBox& box, CacheJobMode mode, const std::vector<uint32_t>& objects);
    CacheBox window(uint32_t level) const;
    CacheBox brickBox(uint32_t level, glm::ivec3 brick) const;
    void fillLevelsGpu();

    // layout
    uint32_t m_resolution = 0, m_levelCount = 0, m_maxLevels = 0;
    float m_voxel0 = 0.0f;
    float m_settingVoxel = -1.0f;
    std::vector<glm::ivec3> m_origin;
    bool m_valid = false, m_layoutChanged = false;
    // this frame
    std::vector<glm::vec3> m_lo, m_hi;  // world boxes of the frame's objects
    std::vector<bool> m_unbounded;
    std::vector<uint32_t> m_unboundedList;
    std::vector<Grid> m_grids;
    std::vector<uint32_t> m_stamp;
    uint32_t m_stampValue = 0;
    std::vector<CacheJob> m_jobs;
    std::vector<uint32_t> m_list;
    uint32_t m_splatJobs = 0;
    std::vector<CacheLevelGpu> m_levelsGpu;
    ClipmapFrameStats m_stats;
    // across frames
    std::unordered_map<uint32_t, Tracked> m_tracked;
    std::deque<CacheBrickKey> m_queue;  // FIFO
    std::set<CacheBrickKey> m_queued;
};

}  // namespace penumbra::render
