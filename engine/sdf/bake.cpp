// Bake driver: clean-up, grid placement, BVH, exact distances (threads over bricks, each brick
// walked in a serpentine order so every query is seeded with the previous voxel's closest
// triangle), then the sign.
//
// Sign with the winding number or parity (the rule that keeps the number of evaluations small):
// the grid is covered by cells whose corners are voxel centres, starting with cells of
// kTopCell^3 voxels. A cell is "surface-free" when every voxel centre in it lies farther than
// half a voxel diagonal from the mesh: every point of the cell is within half a voxel diagonal
// of one of its voxel centres, so then no triangle passes through the cell, and the winding
// number is harmonic there (constant for closed meshes). The winding number is evaluated at the
// cell's corners; if the cell is surface-free and all corners are on the same side of 0.5, every
// voxel of the cell takes that side. Otherwise the cell is split in halves along each axis and the
// rule applies again, down to 2x2x2 cells whose voxels are all corners, i.e. evaluated exactly.
// So the winding number is evaluated on the coarse lattice, in a band of about one voxel around
// the surface and around the (open meshes') w = 0.5 level set away from the surface.
//
// auto on a closed, consistently oriented mesh: the angle-weighted pseudonormal of each voxel's
// closest feature gives the sign for free during the distance queries. It is then checked: the sign
// may only change between neighbours whose segment can cross the surface (d(u) + d(v) <= voxel);
// where it changes between neighbours farther out, the mesh intersects or touches itself or holds
// nested shells, and the winding number (signed ray crossings, exact for closed meshes) corrects
// the affected region by spreading from those voxels (see repairPseudonormalSigns()).
#include "engine/sdf/bake.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <system_error>
#include <thread>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "engine/core/log.h"
#include "engine/sdf/bvh.h"
#include "engine/sdf/huge_pages.h"
#include "engine/sdf/winding.h"

namespace penumbra::sdf {

const char* toString(BakeQuality q) {
    switch (q) {
        case BakeQuality::Low:
            return "low";
        case BakeQuality::Medium:
            return "medium";
        case BakeQuality::High:
            return "high";
    }
    return "medium";
}

PsdfSign psdfSign(SignMethod m) {
    switch (m) {
        case SignMethod::Winding:
            return PsdfSign::Winding;
        case SignMethod::Pseudonormal:
            return PsdfSign::Pseudonormal;
        case SignMethod::Parity:
            return PsdfSign::Parity;
        case SignMethod::Auto:
            break;
    }
    return PsdfSign::Unknown;
}

const char* toString(SignMethod m) {
    switch (m) {
        case SignMethod::Auto:
            return "auto";
        case SignMethod::Winding:
            return "winding";
        case SignMethod::Pseudonormal:
            return "pseudonormal";
        case SignMethod::Parity:
            return "parity";
    }
    return "auto";
}

bool parseSignMethod(const std::string& text, SignMethod& out) {
    for (SignMethod m :
         {SignMethod::Auto, SignMethod::Winding, SignMethod::Pseudonormal, SignMethod::Parity}) {
        if (text == toString(m)) {
            out = m;
            return true;
        }
    }
    return false;
}

// Low / Medium / High: 64 / 128 / 256 voxels along the longest axis of the padded grid. An
// elongated mesh would then be only a few voxels thick along its shortest axis, too thin for
// trilinear reconstruction, so the resolution is raised (at most doubled) until the shortest
// axis of the mesh spans base / 8 voxels (8 / 16 / 32). Axes shorter than 1/64 of the longest
// count as flat (a planar mesh is fine at any resolution) and are ignored.
uint32_t automaticResolution(const MeshDiagnostics& diagnostics, BakeQuality quality) {
    const uint32_t base = quality == BakeQuality::Low ? 64 : quality == BakeQuality::High ? 256 : 128;
    const glm::dvec3 extent = diagnostics.boundsMax - diagnostics.boundsMin;
    const double longest = std::max({extent.x, extent.y, extent.z});
    if (!(longest > 0)) return base;
    double shortest = longest;
    for (int a = 0; a < 3; ++a) {
        if (extent[a] >= longest / 64) shortest = std::min(shortest, extent[a]);
    }
    const double wanted = std::ceil(double(base) / 8.0 * longest / shortest);
    return static_cast<uint32_t>(std::clamp(wanted, double(base), double(2 * base)));
}

namespace {

constexpr uint64_t kMaxVoxels = 1ull << 30;  // 1024^3
constexpr uint32_t kMaxAxisVoxels = 16384;
constexpr uint32_t kBrick = 8;         // distance phase: voxels per task along each axis
constexpr uint32_t kTopCell = 8;       // winding / parity: top-level cell size in voxels
constexpr double kRepairShare = 0.05;  // auto, closed meshes: pseudonormal repair budget

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Runs fn(task) for every task in [0, count) on `threads` workers pulling tasks in order. The
// calling thread only coordinates: it reports progress(fraction of tasks done) while waiting.
void parallelFor(uint32_t threads, size_t count, const std::function<void(size_t)>& fn,
                 const std::function<void(double)>& progress) {
    if (count == 0) return;
    std::atomic<size_t> next{0};
    std::atomic<size_t> done{0};
    std::atomic<bool> failed{false};
    std::exception_ptr error;  // first exception of a worker, rethrown here after the join
    std::mutex mutex;
    std::condition_variable cv;
    auto work = [&] {
        try {
            for (;;) {
                const size_t task = next.fetch_add(1);
                if (task >= count || failed.load()) break;
                fn(task);
                if (done.fetch_add(1) + 1 == count && progress) {
                    // Under the mutex, so the coordinator cannot miss the wake-up between its
                    // check and its wait.
                    std::lock_guard lock(mutex);
                    cv.notify_all();
                }
            }
        } catch (...) {
            std::lock_guard lock(mutex);
            if (!error) error = std::current_exception();
            failed = true;
            cv.notify_all();
        }
    };
    const size_t workers = std::min<size_t>(threads, count);
    std::vector<std::thread> pool;
    pool.reserve(workers);
    for (size_t t = 0; t < workers; ++t) {
        try {
            pool.emplace_back(work);
        } catch (const std::system_error&) {
            break;
        }
    }
    if (pool.empty()) work();  // no thread could be started: do it here
    if (progress) {
        std::unique_lock lock(mutex);
        while (done.load() < count && !failed.load()) {
            cv.wait_for(lock, std::chrono::milliseconds(100));
            if (!failed.load()) progress(double(done.load()) / double(count));
        }
    }
    for (std::thread& t : pool) t.join();
    if (error) std::rethrow_exception(error);
}

struct Placement {
    glm::uvec3 dims{0};
    double voxelSize = 0;
};

bool placeGrid(const MeshDiagnostics& d, const BakeSettings& s, Placement& out, std::string& error) {
    const glm::dvec3 extent = d.boundsMax - d.boundsMin;
    const double longest = std::max({extent.x, extent.y, extent.z});
    const double padding = s.padding;
    uint32_t resolution = s.resolution;
    if (resolution == 0) {
        if (std::isnan(s.voxelSize) || s.voxelSize < 0 || std::isinf(s.voxelSize)) {
            error = fmt::format("voxel size {} is not a positive finite number", s.voxelSize);
            return false;
        }
        if (s.voxelSize == 0) resolution = automaticResolution(d, s.quality);
    }
    double h = 0;
    int longestAxis = 0;
    for (int a = 1; a < 3; ++a) {
        if (extent[a] > extent[longestAxis]) longestAxis = a;
    }
    if (resolution > 0) {
        if (double(resolution) <= 2 * padding) {
            error = fmt::format("resolution {} must exceed twice the padding ({} voxels on each side)",
                                resolution, s.padding);
            return false;
        }
        h = longest / (double(resolution) - 2 * padding);
        if (!(h > 0) || !std::isfinite(h)) {
            error = "mesh bounds have zero extent";
            return false;
        }
    } else {
        h = s.voxelSize;
    }
    double dims[3];
    uint64_t total = 1;
    for (int a = 0; a < 3; ++a) {
        const double inner = std::max(1.0, std::ceil(extent[a] / h * (1 - 1e-12)));
        dims[a] = (resolution > 0 && a == longestAxis) ? double(resolution) : inner + 2 * padding;
        if (!(dims[a] <= kMaxAxisVoxels)) {
            error = fmt::format(
                "grid would need {:.0f} voxels along axis {} (limit {}): use a larger voxel size, a lower "
                "resolution or less padding",
                dims[a], "xyz"[a], kMaxAxisVoxels);
            return false;
        }
    }
    for (int a = 0; a < 3; ++a) {
        out.dims[a] = static_cast<uint32_t>(dims[a]);
        total *= out.dims[a];
    }
    if (!(h >= kMinVoxelSize)) {
        error = fmt::format(
            "voxel size {:.6g} is below the smallest normal 32-bit float ({:.6g}): the distances could not "
            "be "
            "stored to a voxel's precision (mesh extent {:.6g}); scale the mesh up or use fewer voxels",
            h, kMinVoxelSize, longest);
        return false;
    }
    const double diagonal = gridDiagonal(out.dims, h);
    if (!(diagonal <= kMaxGridDiagonal)) {
        error = fmt::format(
            "mesh extent {:.6g} is too large: the grid's diagonal {:.6g} (the largest distance it can hold) "
            "exceeds the largest 32-bit float ({:.6g}); scale the mesh down",
            longest, diagonal, kMaxGridDiagonal);
        return false;
    }
    if (total > kMaxVoxels) {
        error = fmt::format(
            "grid of {}x{}x{} = {} voxels exceeds the limit of {} voxels (1024^3): use a larger voxel size "
            "or "
            "a lower resolution",
            out.dims.x, out.dims.y, out.dims.z, total, kMaxVoxels);
        return false;
    }
    out.voxelSize = h;
    return true;
}

// Angle-weighted pseudonormals (Baerentzen & Aanaes) of the closest feature, computed on demand
// from the vertex rings: the face normal; for an edge the sum of the unit normals of the
// triangles sharing it; for a vertex the sum of the unit normals of its triangles, each weighted by
// the triangle's angle at the vertex. A point is inside when (p - closest) . normal < 0.
class Pseudonormals {
public:
    explicit Pseudonormals(const CleanMesh& mesh) : m_mesh(mesh) {}

    glm::dvec3 normal(const ClosestHit& hit) const {
        const glm::uvec3& tri = m_mesh.triangles[hit.triangle];
        if (isEdge(hit.feature)) {
            const uint32_t k = featureIndex(hit.feature);
            const uint32_t a = tri[k], b = tri[(k + 1) % 3];
            glm::dvec3 sum(0);
            for (uint32_t r = m_mesh.ringStart[a]; r < m_mesh.ringStart[a + 1]; ++r) {
                const glm::uvec3& u = m_mesh.triangles[m_mesh.ringTriangles[r]];
                if (u.x == b || u.y == b || u.z == b) sum += unitNormal(u);
            }
            return sum;
        }
        if (isVertex(hit.feature)) {
            const uint32_t v = tri[featureIndex(hit.feature)];
            glm::dvec3 sum(0);
            for (uint32_t r = m_mesh.ringStart[v]; r < m_mesh.ringStart[v + 1]; ++r) {
                const glm::uvec3& u = m_mesh.triangles[m_mesh.ringTriangles[r]];
                const int k = u.x == v ? 0 : u.y == v ? 1 : 2;
                const glm::dvec3& p = m_mesh.positions[v];
                const glm::dvec3 e1 = m_mesh.positions[u[(k + 1) % 3]] - p;
                const glm::dvec3 e2 = m_mesh.positions[u[(k + 2) % 3]] - p;
                const double angle = std::atan2(glm::length(glm::cross(e1, e2)), glm::dot(e1, e2));
                sum += angle * unitNormal(u);
            }
            return sum;
        }
        return unitNormal(tri);
    }

private:
    glm::dvec3 unitNormal(const glm::uvec3& t) const {
        const glm::dvec3& a = m_mesh.positions[t.x];
        const glm::dvec3 n = glm::cross(m_mesh.positions[t.y] - a, m_mesh.positions[t.z] - a);
        const double len = glm::length(n);
        return len > 0 ? n / len : glm::dvec3(0);
    }

    const CleanMesh& m_mesh;
};

// Voxel states of the sign phase (bits, set with relaxed atomic ORs from several threads).
constexpr uint8_t kFillInside = 1;
constexpr uint8_t kFillOutside = 2;
constexpr uint8_t kEvaluated = 4;

class SignSolver {
public:
    SignSolver(const SdfGrid& grid, const glm::dvec3& originLocal, const WindingNumber& winding, bool parity)
        : m_grid(grid), m_originLocal(originLocal), m_winding(winding), m_parity(parity) {
        const size_t n = grid.distances.size();
        resizeHuge(m_w, n, std::numeric_limits<float>::quiet_NaN());
        resizeHuge(m_state, n, uint8_t(0));
        m_free = 0.5 * std::sqrt(3.0) * grid.voxelSize * (1 + 1e-6);
    }

    glm::dvec3 local(uint32_t i, uint32_t j, uint32_t k) const {
        return m_originLocal + (glm::dvec3(i, j, k) + 0.5) * m_grid.voxelSize;
    }

    // Winding number (or parity as 0 / 1) at a voxel centre, computed once.
    float w(uint32_t i, uint32_t j, uint32_t k) {
        const size_t idx = m_grid.index(i, j, k);
        const float cached = std::atomic_ref<float>(m_w[idx]).load(std::memory_order_relaxed);
        if (!std::isnan(cached)) return cached;
        const glm::dvec3 p = local(i, j, k);
        const float value = m_parity ? (m_winding.parityInside(p) ? 1.0f : 0.0f) : float(m_winding.fast(p));
        std::atomic_ref<float>(m_w[idx]).store(value, std::memory_order_relaxed);
        std::atomic_ref<uint8_t>(m_state[idx]).fetch_or(kEvaluated, std::memory_order_relaxed);
        m_evaluations.fetch_add(1, std::memory_order_relaxed);
        return value;
    }

    // Cell with corner voxels [lo, hi] (inclusive) on each axis.
    void solveCell(glm::uvec3 lo, glm::uvec3 hi) {
        const uint32_t xs[2] = {lo.x, hi.x}, ys[2] = {lo.y, hi.y}, zs[2] = {lo.z, hi.z};
        int inside = 0, outside = 0;
        for (uint32_t c = 0; c < 8; ++c) {
            const float value = w(xs[c & 1], ys[(c >> 1) & 1], zs[c >> 2]);
            (value > 0.5f ? inside : outside) += 1;
        }
        const glm::uvec3 ext = hi - lo;
        if (ext.x <= 1 && ext.y <= 1 && ext.z <= 1) return;  // every voxel is a corner
        if ((inside == 0 || outside == 0) && surfaceFree(lo, hi)) {
            fill(lo, hi, inside > 0 ? kFillInside : kFillOutside);
            return;
        }
        uint32_t xsplit[3] = {lo.x, hi.x, hi.x}, ysplit[3] = {lo.y, hi.y, hi.y},
                 zsplit[3] = {lo.z, hi.z, hi.z};
        int nx = 1, ny = 1, nz = 1;
        if (ext.x >= 2) xsplit[1] = lo.x + ext.x / 2, nx = 2;
        if (ext.y >= 2) ysplit[1] = lo.y + ext.y / 2, ny = 2;
        if (ext.z >= 2) zsplit[1] = lo.z + ext.z / 2, nz = 2;
        if (nx == 1) xsplit[1] = hi.x;
        if (ny == 1) ysplit[1] = hi.y;
        if (nz == 1) zsplit[1] = hi.z;
        for (int c = 0; c < nz; ++c) {
            for (int b = 0; b < ny; ++b) {
                for (int a = 0; a < nx; ++a) {
                    solveCell(glm::uvec3(xsplit[a], ysplit[b], zsplit[c]),
                              glm::uvec3(xsplit[a + 1], ysplit[b + 1], zsplit[c + 1]));
                }
            }
        }
    }

    // Final sign of a voxel: evaluated value first, then the fill; a voxel filled with both signs
    // by neighbouring cells (possible only where w is near 0.5) is evaluated.
    bool inside(uint32_t i, uint32_t j, uint32_t k) {
        const size_t idx = m_grid.index(i, j, k);
        const uint8_t state = std::atomic_ref<uint8_t>(m_state[idx]).load(std::memory_order_relaxed);
        if (!(state & kEvaluated) && state == kFillInside) return true;
        if (!(state & kEvaluated) && state == kFillOutside) return false;
        return w(i, j, k) > 0.5f;
    }

    bool evaluated(size_t idx) const { return (m_state[idx] & kEvaluated) != 0; }
    float cachedW(size_t idx) const { return m_w[idx]; }
    uint64_t evaluations() const { return m_evaluations.load(); }

private:
    bool surfaceFree(glm::uvec3 lo, glm::uvec3 hi) const {
        const float limit = static_cast<float>(m_free);
        for (uint32_t k = lo.z; k <= hi.z; ++k) {
            for (uint32_t j = lo.y; j <= hi.y; ++j) {
                const float* row = m_grid.distances.data() + m_grid.index(0, j, k);
                for (uint32_t i = lo.x; i <= hi.x; ++i) {
                    if (!(row[i] > limit)) return false;
                }
            }
        }
        return true;
    }

    void fill(glm::uvec3 lo, glm::uvec3 hi, uint8_t bit) {
        for (uint32_t k = lo.z; k <= hi.z; ++k) {
            for (uint32_t j = lo.y; j <= hi.y; ++j) {
                for (uint32_t i = lo.x; i <= hi.x; ++i) {
                    std::atomic_ref<uint8_t>(m_state[m_grid.index(i, j, k)])
                        .fetch_or(bit, std::memory_order_relaxed);
                }
            }
        }
    }

    const SdfGrid& m_grid;
    glm::dvec3 m_originLocal;
    const WindingNumber& m_winding;
    bool m_parity;
    double m_free = 0;
    std::vector<float> m_w;
    std::vector<uint8_t> m_state;
    std::atomic<uint64_t> m_evaluations{0};
};

// Winding number of a closed, consistently oriented mesh at p: the signed count of crossings along
// a ray, median over three directions (a ray through an edge or a vertex may miscount).
int closedWindingNumber(const TriangleBvh& bvh, const glm::dvec3& p) {
    static const glm::dvec3 kDirections[3] = {{0.7548776662, 0.5698402910, 0.3245284281},
                                              {-0.4338837391, 0.7818314825, 0.4476209926},
                                              {0.2817325568, -0.3826834324, 0.8797958971}};
    int w[3];
    for (int r = 0; r < 3; ++r) w[r] = bvh.signedCrossings(p, kDirections[r]);
    return std::max(std::min(w[0], w[1]), std::min(std::max(w[0], w[1]), w[2]));
}

// Lattice coordinates 0, step, 2 step, ..., n - 1 along one axis.
std::vector<uint32_t> latticeAxis(uint32_t n, uint32_t step) {
    std::vector<uint32_t> v;
    for (uint32_t x = 0; x + 1 < n; x += step) v.push_back(x);
    v.push_back(n - 1);
    return v;
}

}  // namespace

namespace {

// Everything after the clean-up works in a normalised frame: the local coordinates scaled by a
// power of two (exact in binary floating point) that brings the longest extent into [0.5, 1), so
// neither the BVH's float bounds nor squared distances overflow or underflow whatever the mesh's
// units. Distances are scaled back at the end; for meshes of ordinary size the result is the same.
struct UnitScale {
    double toUnit = 1;
    double fromUnit = 1;
};

UnitScale unitScale(const glm::dvec3& extent) {
    int exponent = 0;
    std::frexp(std::max({extent.x, extent.y, extent.z}), &exponent);
    return {std::ldexp(1.0, -exponent), std::ldexp(1.0, exponent)};
}

// Inside-out: flips a closed mesh whose triangles all face inward (so its winding number is -1
// inside and its pseudonormals point in) when the settings ask for it. Returns the description of
// the mesh's orientation used in the sign reason.
std::string orientMesh(CleanMesh& clean, const BakeSettings& settings, BakeResult& result) {
    const MeshDiagnostics& diag = clean.diagnostics;
    if (diag.inwardOriented && settings.flipInsideOut) {
        for (glm::uvec3& t : clean.triangles) std::swap(t.y, t.z);
        for (glm::uvec3& t : clean.windingTriangles) std::swap(t.y, t.z);
        result.flippedInsideOut = true;
        log::warn(
            "bake: the mesh is closed and all its triangles face inward (signed volume {:.6g}): flipped them "
            "so "
            "its inside bakes negative",
            diag.signedVolume);
    }
    return !diag.inwardOriented ? "closed, consistently oriented manifold"
           : result.flippedInsideOut
               ? "closed manifold, consistently oriented inward (inside out, flipped)"
               : "closed manifold, consistently oriented inward (inside out, not flipped)";
}

struct SignChoice {
    SignMethod method = SignMethod::Auto;
    bool repairPseudonormal = false;  // auto on a closed, consistent mesh: pseudonormal, then checked
};

// The sign method for `requested` (auto picks from the mesh's topology) and, except for the
// checked pseudonormal whose reason depends on the check, the reason for it.
SignChoice chooseSignMethod(const MeshDiagnostics& diag, SignMethod requested, const std::string& orientation,
                            std::string& reason) {
    SignChoice choice;
    choice.method = requested;
    if (requested != SignMethod::Auto) {
        reason = fmt::format("{} requested", toString(requested));
        if (diag.inwardOriented) reason += "; " + orientation;
    } else if (diag.closedManifold && diag.inconsistentEdges == 0) {
        choice.method = SignMethod::Pseudonormal;
        choice.repairPseudonormal = true;
    } else if (diag.closedManifold) {
        choice.method = SignMethod::Winding;
        reason = fmt::format("closed manifold but {} edges are inconsistently oriented -> winding",
                             diag.inconsistentEdges);
    } else {
        choice.method = SignMethod::Winding;
        reason =
            fmt::format("open or non-manifold mesh ({} boundary edges, {} non-manifold edges) -> winding",
                        diag.boundaryEdges, diag.nonManifoldEdges);
    }
    return choice;
}

// Progress of the whole bake as one fraction: distance first (distanceShare of it), then the sign.
class BakeProgress {
public:
    BakeProgress(const BakeSettings& settings, double distanceShare)
        : m_settings(settings), m_distanceShare(distanceShare) {}

    void report(double fraction, const char* phase) const {
        if (m_settings.progress) m_settings.progress(std::clamp(fraction, 0.0, 1.0), phase);
    }

    // parallelFor callbacks (empty without a progress callback): the distance phase, and the
    // first `share` of the sign phase.
    std::function<void(double)> distance() const {
        if (!m_settings.progress) return {};
        return [this](double f) { report(f * m_distanceShare, "distance"); };
    }
    std::function<void(double)> sign(double share) const {
        if (!m_settings.progress) return {};
        return
            [this, share](double f) { report(m_distanceShare + share * f * (1 - m_distanceShare), "sign"); };
    }

private:
    const BakeSettings& m_settings;
    double m_distanceShare;
};

// Sets up the grid of the placement in the normalised frame (distances all 0) and returns the
// local position of its corner.
glm::dvec3 allocateGrid(SdfGrid& grid, const Placement& placement, const glm::dvec3& center, double toUnit) {
    grid.dims = placement.dims;
    grid.voxelSize = placement.voxelSize * toUnit;
    grid.origin = center - 0.5 * glm::dvec3(grid.dims) * placement.voxelSize;
    resizeHuge(grid.distances, size_t(grid.dims.x) * grid.dims.y * grid.dims.z, 0.0f);
    return -0.5 * glm::dvec3(grid.dims) * grid.voxelSize;
}

// Distances: one task per brick of kBrick^3 voxels, walked back and forth along x and y so
// consecutive voxels are neighbours and each query starts from the previous voxel's closest
// triangle (bricks keep the BVH nodes a task touches few and cached). With `negative`, the
// pseudonormal sign of every voxel too (1: inside).
void computeDistances(SdfGrid& grid, const glm::dvec3& originLocal, const TriangleBvh& bvh,
                      const Pseudonormals& pseudonormals, std::vector<uint8_t>* negative, uint32_t threads,
                      const std::function<void(double)>& progress) {
    const glm::uvec3 bricks = (grid.dims + (kBrick - 1)) / kBrick;
    parallelFor(
        threads, size_t(bricks.x) * bricks.y * bricks.z,
        [&](size_t task) {
            const glm::uvec3 b(task % bricks.x, (task / bricks.x) % bricks.y,
                               task / (size_t(bricks.x) * bricks.y));
            const glm::uvec3 lo = b * kBrick;
            const glm::uvec3 hi = glm::min(lo + kBrick, grid.dims);
            uint32_t seed = UINT32_MAX;
            uint32_t row = 0;
            for (uint32_t k = lo.z; k < hi.z; ++k) {
                for (uint32_t jj = 0; jj < hi.y - lo.y; ++jj) {
                    const uint32_t j = ((k - lo.z) & 1) ? hi.y - 1 - jj : lo.y + jj;
                    for (uint32_t ii = 0; ii < hi.x - lo.x; ++ii) {
                        const uint32_t i = (row & 1) ? hi.x - 1 - ii : lo.x + ii;
                        const glm::dvec3 p = originLocal + (glm::dvec3(i, j, k) + 0.5) * grid.voxelSize;
                        const ClosestHit hit = bvh.closestSeeded(p, seed);
                        seed = hit.triangle;
                        const size_t idx = grid.index(i, j, k);
                        grid.distances[idx] = static_cast<float>(hit.distance);
                        if (negative) {
                            (*negative)[idx] = glm::dot(p - hit.point, pseudonormals.normal(hit)) < 0 ? 1 : 0;
                        }
                    }
                    ++row;
                }
            }
        },
        progress);
}

// Both voxels of every pair of neighbours with different pseudonormal signs whose distances add
// up to more than `separated` (so their segment cannot cross the surface).
std::vector<size_t> inconsistentPairs(const SdfGrid& grid, const std::vector<uint8_t>& negative,
                                      float separated, uint32_t threads) {
    const glm::uvec3 dims = grid.dims;
    const size_t stride[3] = {1, dims.x, size_t(dims.x) * dims.y};
    std::vector<size_t> wave;
    std::mutex waveMutex;
    parallelFor(threads, dims.z,
                [&](size_t k) {
                    std::vector<size_t> local;
                    for (uint32_t j = 0; j < dims.y; ++j) {
                        for (uint32_t i = 0; i < dims.x; ++i) {
                            const size_t idx = grid.index(i, j, uint32_t(k));
                            const size_t next[3] = {i + 1 < dims.x ? idx + 1 : idx,
                                                    j + 1 < dims.y ? idx + stride[1] : idx,
                                                    k + 1 < dims.z ? idx + stride[2] : idx};
                            for (size_t n : next) {
                                if (negative[n] != negative[idx] &&
                                    grid.distances[idx] + grid.distances[n] > separated) {
                                    local.push_back(idx);
                                    local.push_back(n);
                                }
                            }
                        }
                    }
                    if (!local.empty()) {
                        std::lock_guard lock(waveMutex);
                        wave.insert(wave.end(), local.begin(), local.end());
                    }
                },
                {});
    return wave;
}

struct SignRepair {
    uint64_t pairs = 0;        // inconsistent pairs of neighbours found
    uint64_t corrected = 0;    // voxels whose sign the winding number changed
    uint64_t evaluations = 0;  // winding-number evaluations
    bool tooMany = false;      // the repair budget was exceeded: the winding path takes over
};

// A closed, consistently oriented mesh can still intersect itself, hold nested shells or touch
// itself at a vertex; there the closest feature's side is not the inside/outside of the winding
// number. Such errors give themselves away: the sign can only change between neighbouring voxels
// u, v whose segment crosses the surface, which needs d(u) + d(v) <= voxel size (`separated`:
// with the tolerance of float rounding of the stored distances and geometry). Where neighbours
// farther from the mesh disagree, the winding number (for a closed mesh: the signed ray-crossing
// count, median of three rays) is evaluated at both, and from every voxel whose sign it corrects
// the check spreads to that voxel's six neighbours (in waves, threads over each wave), so a wrong
// region connected to such a pair is corrected up to and including its boundary. Should that
// reach kRepairShare of the grid, the repair stops (tooMany).
SignRepair repairPseudonormalSigns(const SdfGrid& grid, const glm::dvec3& originLocal, const TriangleBvh& bvh,
                                   float separated, std::vector<uint8_t>& negative, uint32_t threads) {
    const glm::uvec3 dims = grid.dims;
    const size_t stride[3] = {1, dims.x, size_t(dims.x) * dims.y};
    const size_t voxelCount = grid.distances.size();
    auto forNeighbours = [&](size_t idx, auto&& fn) {
        const uint32_t i = uint32_t(idx % dims.x), j = uint32_t((idx / dims.x) % dims.y),
                       k = uint32_t(idx / stride[2]);
        const uint32_t c[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) {
            if (c[a] > 0) fn(idx - stride[a]);
            if (c[a] + 1 < dims[a]) fn(idx + stride[a]);
        }
    };
    SignRepair repair;
    std::vector<size_t> wave = inconsistentPairs(grid, negative, separated, threads);  // wave 0
    repair.pairs = wave.size() / 2;
    if (wave.empty()) return repair;

    std::vector<uint8_t> queued;
    resizeHuge(queued, voxelCount, uint8_t(0));
    std::sort(wave.begin(), wave.end());
    wave.erase(std::unique(wave.begin(), wave.end()), wave.end());
    for (size_t idx : wave) queued[idx] = 1;
    const uint64_t budget = std::max<uint64_t>(4096, uint64_t(kRepairShare * double(voxelCount)));
    uint64_t processed = 0;
    std::vector<uint8_t> changed;
    while (!wave.empty()) {
        processed += wave.size();
        if (processed > budget) {
            repair.tooMany = true;
            break;
        }
        repair.evaluations += wave.size();
        changed.assign(wave.size(), 0);
        parallelFor(threads, (wave.size() + 255) / 256,
                    [&](size_t chunk) {
                        for (size_t w = chunk * 256; w < std::min(wave.size(), chunk * 256 + 256); ++w) {
                            const size_t idx = wave[w];
                            const uint32_t i = uint32_t(idx % dims.x), j = uint32_t((idx / dims.x) % dims.y),
                                           k = uint32_t(idx / stride[2]);
                            const glm::dvec3 p = originLocal + (glm::dvec3(i, j, k) + 0.5) * grid.voxelSize;
                            const uint8_t inside = closedWindingNumber(bvh, p) > 0 ? 1 : 0;
                            if (inside != negative[idx]) {
                                negative[idx] = inside;
                                changed[w] = 1;
                            }
                        }
                    },
                    {});
        std::vector<size_t> next;
        for (size_t w = 0; w < wave.size(); ++w) {
            if (!changed[w]) continue;
            ++repair.corrected;
            const size_t idx = wave[w];
            forNeighbours(idx, [&](size_t n) {
                if (!queued[n]) {
                    queued[n] = 1;
                    next.push_back(n);
                }
            });
        }
        wave.swap(next);
    }
    return repair;
}

// The sign reason of the checked pseudonormal after its repair.
std::string repairedSignReason(const std::string& orientation, const SignRepair& repair) {
    if (repair.pairs == 0) return orientation + " -> pseudonormal";
    if (!repair.tooMany) {
        return fmt::format(
            "{} -> pseudonormal; {} pairs of neighbouring voxels away from the surface had inconsistent "
            "signs (self-intersection, touching or nested surfaces): the winding number corrected {} "
            "voxels",
            orientation, repair.pairs, repair.corrected);
    }
    return fmt::format(
        "closed manifold, but the pseudonormal sign was wrong over more than {:.0f} % of the grid "
        "(self-intersecting or nested surfaces) -> winding",
        100 * kRepairShare);
}

void applyPseudonormalSigns(SdfGrid& grid, const std::vector<uint8_t>& negative) {
    const size_t voxelCount = grid.distances.size();
    for (size_t i = 0; i < voxelCount; ++i) {
        if (negative[i]) grid.distances[i] = -grid.distances[i];
    }
}

// Signs the grid by the winding number (or parity) with SignSolver's cell subdivision over
// threads (see the top of this file); returns the number of evaluations.
uint64_t applyWindingSigns(SdfGrid& grid, const glm::dvec3& originLocal, const CleanMesh& clean, bool parity,
                           uint32_t threads, const std::function<void(double)>& progress) {
    const WindingNumber winding(clean.positions,
                                clean.separateWinding ? clean.windingTriangles : clean.triangles);
    SignSolver solver(grid, originLocal, winding, parity);
    const auto xs = latticeAxis(grid.dims.x, kTopCell);
    const auto ys = latticeAxis(grid.dims.y, kTopCell);
    const auto zs = latticeAxis(grid.dims.z, kTopCell);
    const size_t cx = std::max<size_t>(1, xs.size() - 1), cy = std::max<size_t>(1, ys.size() - 1),
                 cz = std::max<size_t>(1, zs.size() - 1);
    auto cellRange = [](const std::vector<uint32_t>& axis, size_t c, uint32_t& lo, uint32_t& hi) {
        lo = axis[std::min(c, axis.size() - 1)];
        hi = axis[std::min(c + 1, axis.size() - 1)];
    };
    parallelFor(
        threads, cx * cy * cz,
        [&](size_t cell) {
            glm::uvec3 lo, hi;
            cellRange(xs, cell % cx, lo.x, hi.x);
            cellRange(ys, (cell / cx) % cy, lo.y, hi.y);
            cellRange(zs, cell / (cx * cy), lo.z, hi.z);
            solver.solveCell(lo, hi);
        },
        progress);
    parallelFor(threads, grid.dims.z,
                [&](size_t kk) {
                    const uint32_t k = static_cast<uint32_t>(kk);
                    for (uint32_t j = 0; j < grid.dims.y; ++j) {
                        for (uint32_t i = 0; i < grid.dims.x; ++i) {
                            const size_t idx = grid.index(i, j, k);
                            if (solver.inside(i, j, k)) grid.distances[idx] = -grid.distances[idx];
                        }
                    }
                },
                {});
    return solver.evaluations();
}

// Back to the mesh's units (the range check of placeGrid keeps every distance a finite float),
// with the distance range.
void toMeshUnits(BakeResult& result, double voxelSize, double fromUnit) {
    SdfGrid& grid = result.grid;
    grid.voxelSize = voxelSize;
    float lo = INFINITY, hi = -INFINITY;
    for (float& d : grid.distances) {
        d = static_cast<float>(double(d) * fromUnit);
        lo = std::min(lo, d);
        hi = std::max(hi, d);
    }
    result.minDistance = lo;
    result.maxDistance = hi;
}

void bakeImpl(const assets::MeshData& mesh, const BakeSettings& settings, BakeResult& result) {
    const Clock::time_point start = Clock::now();
    const uint32_t threads =
        settings.threads ? settings.threads : std::max(1u, std::thread::hardware_concurrency());
    CleanMesh clean;
    if (!cleanMesh(mesh, clean, result.error, threads)) {
        result.diagnostics = clean.diagnostics;
        return;
    }
    result.diagnostics = clean.diagnostics;
    result.timings.cleanupMs = msSince(start);
    if (clean.triangles.empty()) {
        result.error = fmt::format("mesh has no non-degenerate triangles ({} degenerate removed)",
                                   clean.diagnostics.degenerateTrianglesRemoved);
        return;
    }

    Placement placement;
    if (!placeGrid(clean.diagnostics, settings, placement, result.error)) return;

    const MeshDiagnostics& diag = clean.diagnostics;
    const glm::dvec3 extent = diag.boundsMax - diag.boundsMin;
    const UnitScale scale = unitScale(extent);
    for (glm::dvec3& p : clean.positions) p *= scale.toUnit;

    const std::string orientation = orientMesh(clean, settings, result);
    const SignChoice choice = chooseSignMethod(diag, settings.sign, orientation, result.signReason);
    SignMethod method = choice.method;
    const BakeProgress progress(
        settings, method == SignMethod::Pseudonormal ? (choice.repairPseudonormal ? 0.97 : 1.0) : 0.6);

    Clock::time_point t0 = Clock::now();
    TriangleBvh bvh;
    bvh.build(clean.positions, clean.triangles, threads);
    const Pseudonormals pseudonormals(clean);
    const bool needPseudonormals = method == SignMethod::Pseudonormal;
    result.timings.bvhMs = msSince(t0);

    SdfGrid& grid = result.grid;  // normalised voxel size and distances until the end
    const glm::dvec3 originLocal = allocateGrid(grid, placement, clean.center, scale.toUnit);
    std::vector<uint8_t> negative;  // pseudonormal signs
    if (needPseudonormals) resizeHuge(negative, grid.distances.size(), uint8_t(0));

    t0 = Clock::now();
    progress.report(0, "distance");
    computeDistances(grid, originLocal, bvh, pseudonormals, needPseudonormals ? &negative : nullptr, threads,
                     progress.distance());
    result.timings.distanceMs = msSince(t0);

    t0 = Clock::now();
    uint64_t windingEvaluations = 0;
    if (choice.repairPseudonormal) {
        const float separated =
            static_cast<float>(grid.voxelSize * (1 + 1e-4) + 1e-6 * glm::length(extent * scale.toUnit));
        const SignRepair repair =
            repairPseudonormalSigns(grid, originLocal, bvh, separated, negative, threads);
        windingEvaluations = repair.evaluations;
        result.signReason = repairedSignReason(orientation, repair);
        if (repair.tooMany) method = SignMethod::Winding;
    }
    if (method == SignMethod::Pseudonormal) {
        applyPseudonormalSigns(grid, negative);
    } else {
        windingEvaluations += applyWindingSigns(grid, originLocal, clean, method == SignMethod::Parity,
                                                threads, progress.sign(0.95));
    }
    result.signUsed = method;
    result.windingEvaluations = windingEvaluations;
    result.timings.signMs = msSince(t0);

    toMeshUnits(result, placement.voxelSize, scale.fromUnit);
    result.ok = true;
    progress.report(1, "sign");
}

}  // namespace

BakeResult bake(const assets::MeshData& mesh, const BakeSettings& settings) {
    BakeResult result;
    try {
        bakeImpl(mesh, settings, result);
    } catch (const std::bad_alloc&) {
        const glm::uvec3 d = result.grid.dims;
        result = BakeResult{};
        result.error = d.x ? fmt::format("out of memory baking a {}x{}x{} grid", d.x, d.y, d.z)
                           : std::string("out of memory preparing the mesh for baking");
    } catch (const std::length_error&) {
        result = BakeResult{};
        result.error = "out of memory (allocation too large) while baking";
    } catch (const std::exception& e) {
        result = BakeResult{};
        result.error = fmt::format("internal error while baking: {}", e.what());
    }
    return result;
}

}  // namespace penumbra::sdf
