#include "engine/sdf/bvh.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <thread>

#include <glm/geometric.hpp>

#include "engine/sdf/huge_pages.h"

#if defined(__SSE2__) || defined(_M_X64)
#include <emmintrin.h>
#endif

namespace penumbra::sdf {

namespace {

constexpr uint32_t kMaxLeafSize = TriangleBvh::kMaxLeafTriangles;
constexpr uint32_t kPancakeTriangles = TriangleBvh::kPancakeTriangles;
// Traversal stack: at most 3 pending siblings per level of the 4-wide tree plus one node's four
// children. Every level splits each path at least once: at most 30 splits on code bits, 31
// halvings of equal codes and one halving of a small range, so depth <= 62.
constexpr int kStackSize = 3 * 64 + 16;

using Node4 = TriangleBvh::Node4;

// Float bounds that contain the double value.
float floatDown(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) > v) f = std::nextafter(f, -INFINITY);
    return f;
}
float floatUp(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) < v) f = std::nextafter(f, INFINITY);
    return f;
}

uint64_t spreadBits(uint64_t x) {  // up to 21 bits -> every third bit
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffull;
    x = (x | x << 16) & 0x1f0000ff0000ffull;
    x = (x | x << 8) & 0x100f00f00f00f00full;
    x = (x | x << 4) & 0x10c30c30c30c30c3ull;
    x = (x | x << 2) & 0x1249249249249249ull;
    return x;
}

// LSD radix sort of 64-bit keys, 8 bits per pass; passes whose byte is the same for every key
// are skipped.
void radixSort(std::vector<uint64_t>& keys) {
    const size_t n = keys.size();
    std::vector<uint64_t> other;
    resizeHuge(other, n);
    uint64_t differing = 0;
    for (size_t i = 1; i < n; ++i) differing |= keys[i] ^ keys[0];
    for (int shift = 0; shift < 64; shift += 8) {
        if (((differing >> shift) & 0xff) == 0) continue;
        size_t count[256] = {};
        for (size_t i = 0; i < n; ++i) ++count[(keys[i] >> shift) & 0xff];
        size_t sum = 0;
        for (size_t& c : count) {
            const size_t k = c;
            c = sum;
            sum += k;
        }
        for (size_t i = 0; i < n; ++i) other[count[(keys[i] >> shift) & 0xff]++] = keys[i];
        keys.swap(other);
    }
}

// An unused lane: marked by child == kEmptyLane, which every traversal tests before using a lane
// (its bound alone cannot mark it: once squared distances overflow to +inf, "inf <= limit" holds
// for an infinite limit). The far-away box keeps its bound large for the SIMD code.
void clearLane(Node4& n, int c) {
    n.minX[c] = n.minY[c] = n.minZ[c] = n.maxX[c] = n.maxY[c] = n.maxZ[c] = 1e30f;
    n.axisX[c] = n.axisY[c] = n.axisZ[c] = n.radius[c] = 0;
    n.axialMin[c] = -INFINITY;
    n.axialMax[c] = INFINITY;
    n.child[c] = TriangleBvh::kEmptyLane;
    n.count[c] = 0;
}

// Lanes of n that hold a child (bit c set for lane c).
inline uint32_t usedLanes(const Node4& n) {
    return (n.child[0] != TriangleBvh::kEmptyLane ? 1u : 0u) |
           (n.child[1] != TriangleBvh::kEmptyLane ? 2u : 0u) |
           (n.child[2] != TriangleBvh::kEmptyLane ? 4u : 0u) |
           (n.child[3] != TriangleBvh::kEmptyLane ? 8u : 0u);
}

// Pancake of lane c (leaf packets [first, end); its box is set): axis = mean normal; axial range
// and lateral radius computed in double from the float axis and centre that the query uses,
// rounded outward. Left absent when the normals spread too far for a thin disk.
void makePancake(Node4& node, int c, const TriangleBvh::LeafPacket* packets, const uint32_t* slotIds,
                 uint32_t first, uint32_t end) {
    node.axisX[c] = node.axisY[c] = node.axisZ[c] = node.radius[c] = 0;
    node.axialMin[c] = -INFINITY;
    node.axialMax[c] = INFINITY;
    auto corner = [&](uint32_t p, uint32_t l, int k) {
        const TriangleBvh::LeafPacket& t = packets[p];
        return k == 0   ? glm::dvec3(t.ax[l], t.ay[l], t.az[l])
               : k == 1 ? glm::dvec3(t.bx[l], t.by[l], t.bz[l])
                        : glm::dvec3(t.cx[l], t.cy[l], t.cz[l]);
    };
    glm::dvec3 sum(0);
    double area = 0;
    for (uint32_t p = first; p < end; ++p) {
        for (uint32_t l = 0; l < 4 && slotIds[4 * size_t(p) + l] != UINT32_MAX; ++l) {
            const glm::dvec3 a = corner(p, l, 0);
            const glm::dvec3 n = glm::cross(corner(p, l, 1) - a, corner(p, l, 2) - a);
            sum += n;
            area += glm::length(n);
        }
    }
    const double len = glm::length(sum);
    if (!(len > 0.5 * area)) return;
    const glm::vec3 axisF(sum / len);
    const glm::dvec3 axis(axisF);
    const glm::vec3 centreF(0.5f * (node.minX[c] + node.maxX[c]), 0.5f * (node.minY[c] + node.maxY[c]),
                            0.5f * (node.minZ[c] + node.maxZ[c]));
    const glm::dvec3 centre(centreF);
    double lo = INFINITY, hi = -INFINITY, radius2 = 0;
    for (uint32_t p = first; p < end; ++p) {
        for (uint32_t l = 0; l < 4 && slotIds[4 * size_t(p) + l] != UINT32_MAX; ++l) {
            for (int k = 0; k < 3; ++k) {
                const glm::dvec3 d = corner(p, l, k) - centre;
                const double axial = glm::dot(axis, d);
                const glm::dvec3 lateral = glm::cross(axis, d);
                lo = std::min(lo, axial);
                hi = std::max(hi, axial);
                radius2 = std::max(radius2, glm::dot(lateral, lateral));
            }
        }
    }
    node.axisX[c] = axisF.x;
    node.axisY[c] = axisF.y;
    node.axisZ[c] = axisF.z;
    node.radius[c] = floatUp(std::sqrt(radius2));
    node.axialMin[c] = floatDown(lo);
    node.axialMax[c] = floatUp(hi);
}

// Lower bounds of the squared distance from p to anything in each of a node's four children: the
// larger of the box distance and the pancake distance (lateral |axis x d| beyond the radius, axial
// outside the range). |axis| differs from 1 by float rounding; that and the float arithmetic are
// covered by the query's slack.
#if defined(__SSE2__) || defined(_M_X64)
inline void boundDistances(const Node4& n, float px, float py, float pz, float out[4]) {
    const __m128 x = _mm_set1_ps(px), y = _mm_set1_ps(py), z = _mm_set1_ps(pz);
    const __m128 zero = _mm_setzero_ps(), half = _mm_set1_ps(0.5f);
    const __m128 minX = _mm_load_ps(n.minX), minY = _mm_load_ps(n.minY), minZ = _mm_load_ps(n.minZ);
    const __m128 maxX = _mm_load_ps(n.maxX), maxY = _mm_load_ps(n.maxY), maxZ = _mm_load_ps(n.maxZ);
    const __m128 dx = _mm_max_ps(_mm_max_ps(_mm_sub_ps(minX, x), _mm_sub_ps(x, maxX)), zero);
    const __m128 dy = _mm_max_ps(_mm_max_ps(_mm_sub_ps(minY, y), _mm_sub_ps(y, maxY)), zero);
    const __m128 dz = _mm_max_ps(_mm_max_ps(_mm_sub_ps(minZ, z), _mm_sub_ps(z, maxZ)), zero);
    const __m128 box = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    const __m128 cx = _mm_sub_ps(x, _mm_mul_ps(half, _mm_add_ps(minX, maxX)));
    const __m128 cy = _mm_sub_ps(y, _mm_mul_ps(half, _mm_add_ps(minY, maxY)));
    const __m128 cz = _mm_sub_ps(z, _mm_mul_ps(half, _mm_add_ps(minZ, maxZ)));
    const __m128 ax = _mm_load_ps(n.axisX), ay = _mm_load_ps(n.axisY), az = _mm_load_ps(n.axisZ);
    const __m128 axial = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ax, cx), _mm_mul_ps(ay, cy)), _mm_mul_ps(az, cz));
    const __m128 lx = _mm_sub_ps(_mm_mul_ps(ay, cz), _mm_mul_ps(az, cy));
    const __m128 ly = _mm_sub_ps(_mm_mul_ps(az, cx), _mm_mul_ps(ax, cz));
    const __m128 lz = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
    const __m128 lateral =
        _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(lx, lx), _mm_mul_ps(ly, ly)), _mm_mul_ps(lz, lz)));
    const __m128 dr = _mm_max_ps(_mm_sub_ps(lateral, _mm_load_ps(n.radius)), zero);
    const __m128 da = _mm_max_ps(
        _mm_max_ps(_mm_sub_ps(_mm_load_ps(n.axialMin), axial), _mm_sub_ps(axial, _mm_load_ps(n.axialMax))),
        zero);
    const __m128 pancake = _mm_add_ps(_mm_mul_ps(dr, dr), _mm_mul_ps(da, da));
    _mm_storeu_ps(out, _mm_max_ps(pancake, box));
}
#else
inline void boundDistances(const Node4& n, float px, float py, float pz, float out[4]) {
    for (int c = 0; c < 4; ++c) {
        const float dx = std::max(std::max(n.minX[c] - px, px - n.maxX[c]), 0.0f);
        const float dy = std::max(std::max(n.minY[c] - py, py - n.maxY[c]), 0.0f);
        const float dz = std::max(std::max(n.minZ[c] - pz, pz - n.maxZ[c]), 0.0f);
        const float box = dx * dx + dy * dy + dz * dz;
        const float cx = px - 0.5f * (n.minX[c] + n.maxX[c]);
        const float cy = py - 0.5f * (n.minY[c] + n.maxY[c]);
        const float cz = pz - 0.5f * (n.minZ[c] + n.maxZ[c]);
        const float axial = n.axisX[c] * cx + n.axisY[c] * cy + n.axisZ[c] * cz;
        const float lx = n.axisY[c] * cz - n.axisZ[c] * cy;
        const float ly = n.axisZ[c] * cx - n.axisX[c] * cz;
        const float lz = n.axisX[c] * cy - n.axisY[c] * cx;
        const float dr = std::max(std::sqrt(lx * lx + ly * ly + lz * lz) - n.radius[c], 0.0f);
        const float da = std::max(std::max(n.axialMin[c] - axial, axial - n.axialMax[c]), 0.0f);
        out[c] = std::max(dr * dr + da * da, box);
    }
}
#endif

inline glm::dvec3 packetVertex(const TriangleBvh::LeafPacket& t, uint32_t lane, int k) {
    switch (k) {
        case 0:
            return glm::dvec3(t.ax[lane], t.ay[lane], t.az[lane]);
        case 1:
            return glm::dvec3(t.bx[lane], t.by[lane], t.bz[lane]);
        default:
            return glm::dvec3(t.cx[lane], t.cy[lane], t.cz[lane]);
    }
}

// Squared distances from p to a leaf's four triangles in float, without branches: the distance to
// the plane where p projects inside the triangle, else the nearest of the three edges (segment
// parameters clamped; zero-length edges and zero-area triangles fall back to the edges). Float
// rounding makes these differ from the exact values by far less than the query's slack, so they
// only decide which triangles get the exact test. Unused lanes (corners at 1e30) give inf or NaN
// and are never read (a leaf tests its first `count` lanes); a NaN of a used lane (coordinates so
// large that float overflows) sends that triangle to the exact test.
#if defined(__SSE2__) || defined(_M_X64)
struct V3 {
    __m128 x, y, z;
};
inline V3 sub(const V3& a, const V3& b) {
    return {_mm_sub_ps(a.x, b.x), _mm_sub_ps(a.y, b.y), _mm_sub_ps(a.z, b.z)};
}
inline __m128 dot(const V3& a, const V3& b) {
    return _mm_add_ps(_mm_add_ps(_mm_mul_ps(a.x, b.x), _mm_mul_ps(a.y, b.y)), _mm_mul_ps(a.z, b.z));
}
inline V3 cross(const V3& a, const V3& b) {
    return {_mm_sub_ps(_mm_mul_ps(a.y, b.z), _mm_mul_ps(a.z, b.y)),
            _mm_sub_ps(_mm_mul_ps(a.z, b.x), _mm_mul_ps(a.x, b.z)),
            _mm_sub_ps(_mm_mul_ps(a.x, b.y), _mm_mul_ps(a.y, b.x))};
}
// Squared distance from the point at offset d (= p - start) to the segment start + t * e.
inline __m128 segmentDistance2(const V3& d, const V3& e) {
    const __m128 len2 = _mm_max_ps(dot(e, e), _mm_set1_ps(1e-30f));
    const __m128 t = _mm_min_ps(_mm_max_ps(_mm_div_ps(dot(d, e), len2), _mm_setzero_ps()), _mm_set1_ps(1.0f));
    const V3 r{_mm_sub_ps(d.x, _mm_mul_ps(t, e.x)), _mm_sub_ps(d.y, _mm_mul_ps(t, e.y)),
               _mm_sub_ps(d.z, _mm_mul_ps(t, e.z))};
    return dot(r, r);
}
inline void leafDistances(const TriangleBvh::LeafPacket& t, float px, float py, float pz, float out[4]) {
    const V3 p{_mm_set1_ps(px), _mm_set1_ps(py), _mm_set1_ps(pz)};
    const V3 a{_mm_load_ps(t.ax), _mm_load_ps(t.ay), _mm_load_ps(t.az)};
    const V3 b{_mm_load_ps(t.bx), _mm_load_ps(t.by), _mm_load_ps(t.bz)};
    const V3 c{_mm_load_ps(t.cx), _mm_load_ps(t.cy), _mm_load_ps(t.cz)};
    const V3 ab = sub(b, a), bc = sub(c, b), ca = sub(a, c);
    const V3 ap = sub(p, a), bp = sub(p, b), cp = sub(p, c);
    const V3 n = cross(ab, sub(c, a));
    const __m128 nn = dot(n, n);
    const __m128 zero = _mm_setzero_ps();
    const __m128 inside = _mm_and_ps(
        _mm_and_ps(_mm_cmpge_ps(dot(cross(ab, ap), n), zero), _mm_cmpge_ps(dot(cross(bc, bp), n), zero)),
        _mm_and_ps(_mm_cmpge_ps(dot(cross(ca, cp), n), zero), _mm_cmpgt_ps(nn, zero)));
    const __m128 h = dot(ap, n);
    const __m128 plane = _mm_div_ps(_mm_mul_ps(h, h), _mm_max_ps(nn, _mm_set1_ps(1e-30f)));
    const __m128 edges =
        _mm_min_ps(_mm_min_ps(segmentDistance2(ap, ab), segmentDistance2(bp, bc)), segmentDistance2(cp, ca));
    _mm_storeu_ps(out, _mm_or_ps(_mm_and_ps(inside, plane), _mm_andnot_ps(inside, edges)));
}
#else
inline void leafDistances(const TriangleBvh::LeafPacket& t, float px, float py, float pz, float out[4]) {
    for (int l = 0; l < 4; ++l) {
        const glm::vec3 p(px, py, pz), a(t.ax[l], t.ay[l], t.az[l]), b(t.bx[l], t.by[l], t.bz[l]),
            c(t.cx[l], t.cy[l], t.cz[l]);
        auto seg = [](const glm::vec3& d, const glm::vec3& e) {
            const float tt = std::clamp(glm::dot(d, e) / std::max(glm::dot(e, e), 1e-30f), 0.0f, 1.0f);
            const glm::vec3 r = d - tt * e;
            return glm::dot(r, r);
        };
        const glm::vec3 n = glm::cross(b - a, c - a);
        const float nn = glm::dot(n, n);
        const bool inside = glm::dot(glm::cross(b - a, p - a), n) >= 0 &&
                            glm::dot(glm::cross(c - b, p - b), n) >= 0 &&
                            glm::dot(glm::cross(a - c, p - c), n) >= 0 && nn > 0;
        const float h = glm::dot(p - a, n);
        out[l] = inside ? h * h / std::max(nn, 1e-30f)
                        : std::min({seg(p - a, b - a), seg(p - b, c - b), seg(p - c, a - c)});
    }
}
#endif

// Builds the 4-wide tree over Morton-sorted triangles: a node over a range splits it where the
// highest differing code bit changes (halves for equal codes), then splits the largest part again
// until it has four children (parts of at most kMaxLeafSize triangles become leaves). Nodes are
// emitted depth first; boxes come back up the recursion; lane ranges are kept for the pancakes.
struct Builder4 {
    const std::vector<uint64_t>& keys;  // code << 32 | triangle id, sorted
    const std::vector<glm::dvec3>& positions;
    const std::vector<glm::uvec3>& triangles;
    std::vector<Node4>& out;
    std::vector<TriangleBvh::LeafPacket>& packets;
    std::vector<uint32_t>& slotIds;
    std::vector<std::array<uint32_t, 8>>& ranges;  // per node: packets [first, end) of each lane
    uint32_t maxDepth = 0;

    uint32_t split(uint32_t begin, uint32_t end) const {
        // Small ranges: halves, so the leaves come out nearly full.
        if (end - begin <= 2 * kMaxLeafSize) return begin + (end - begin + 1) / 2;
        const uint32_t a = uint32_t(keys[begin] >> 32), b = uint32_t(keys[end - 1] >> 32);
        if (a == b) return begin + (end - begin) / 2;
        const int bit = 31 - std::countl_zero(a ^ b);
        // Codes in the range share the bits above `bit`; those with `bit` set come last.
        const auto it = std::partition_point(keys.begin() + begin, keys.begin() + end,
                                             [bit](uint64_t k) { return ((k >> (32 + bit)) & 1u) == 0; });
        return static_cast<uint32_t>(it - keys.begin());
    }

    // A leaf packet for triangles [begin, end) (at most four); grows `lane` (a box) around them.
    uint32_t leaf(uint32_t begin, uint32_t end, float lane[6]) {
        const uint32_t index = static_cast<uint32_t>(packets.size());
        TriangleBvh::LeafPacket& packet = packets.emplace_back();
        float* fields[9] = {packet.ax, packet.ay, packet.az, packet.bx, packet.by,
                            packet.bz, packet.cx, packet.cy, packet.cz};
        for (uint32_t l = 0; l < 4; ++l) {
            const uint32_t s = begin + l;
            if (s >= end) {
                for (float* f : fields) f[l] = 1e30f;
                slotIds.push_back(UINT32_MAX);
                continue;
            }
            const uint32_t id = static_cast<uint32_t>(keys[s]);
            slotIds.push_back(id);
            for (int k = 0; k < 3; ++k) {
                const glm::dvec3& p = positions[triangles[id][k]];
                for (int a = 0; a < 3; ++a) {
                    const float v = static_cast<float>(p[a]);
                    fields[3 * k + a][l] = v;
                    lane[a] = std::min(lane[a], v);
                    lane[a + 3] = std::max(lane[a + 3], v);
                }
            }
        }
        return index;
    }

    // Emits the node for [begin, end) (more than kMaxLeafSize triangles, or the root); returns its
    // index and its bounds. Lanes are kept in key order, so every subtree's packets are contiguous.
    uint32_t emit(uint32_t begin, uint32_t end, uint32_t depth, float box[6]) {
        maxDepth = std::max(maxDepth, depth);
        uint32_t lo[4] = {begin}, hi[4] = {end};
        int used = 1;
        while (used < 4) {
            int pick = -1;
            uint32_t most = kMaxLeafSize;
            for (int c = 0; c < used; ++c) {
                if (hi[c] - lo[c] > most) {
                    most = hi[c] - lo[c];
                    pick = c;
                }
            }
            if (pick < 0) break;
            const uint32_t mid = split(lo[pick], hi[pick]);
            lo[used] = mid;
            hi[used] = hi[pick];
            hi[pick] = mid;
            ++used;
        }
        for (int c = 1; c < used; ++c) {  // insertion sort by range start
            for (int d = c; d > 0 && lo[d] < lo[d - 1]; --d) {
                std::swap(lo[d], lo[d - 1]);
                std::swap(hi[d], hi[d - 1]);
            }
        }
        const uint32_t index = static_cast<uint32_t>(out.size());
        out.emplace_back();
        ranges.emplace_back();
        for (int k = 0; k < 3; ++k) {
            box[k] = INFINITY;
            box[k + 3] = -INFINITY;
        }
        for (int c = 0; c < 4; ++c) {
            if (c >= used) {
                clearLane(out[index], c);
                ranges[index][2 * c] = ranges[index][2 * c + 1] = 0;
                continue;
            }
            float lane[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
            const uint32_t firstPacket = static_cast<uint32_t>(packets.size());
            uint32_t child = 0, count = hi[c] - lo[c];
            if (count <= kMaxLeafSize) {
                child = leaf(lo[c], hi[c], lane);
            } else {
                child = emit(lo[c], hi[c], depth + 1, lane);
                count = 0;
            }
            ranges[index][2 * c] = firstPacket;
            ranges[index][2 * c + 1] = static_cast<uint32_t>(packets.size());
            Node4& n = out[index];
            n.child[c] = child;
            n.count[c] = count;
            n.minX[c] = lane[0];
            n.minY[c] = lane[1];
            n.minZ[c] = lane[2];
            n.maxX[c] = lane[3];
            n.maxY[c] = lane[4];
            n.maxZ[c] = lane[5];
            for (int k = 0; k < 3; ++k) {
                box[k] = std::min(box[k], lane[k]);
                box[k + 3] = std::max(box[k + 3], lane[k + 3]);
            }
        }
        return index;
    }
};

// Runs fn(begin, end) over [0, count) split in `threads` contiguous parts.
template <typename Fn>
void parallelChunks(uint32_t threads, size_t count, Fn fn) {
    const size_t parts = std::max<size_t>(1, std::min<size_t>(threads, count / 4096));
    std::exception_ptr error;  // first exception of any part, rethrown after the join
    std::mutex mutex;
    auto run = [&](size_t b, size_t e) {
        try {
            fn(b, e);
        } catch (...) {
            std::lock_guard lock(mutex);
            if (!error) error = std::current_exception();
        }
    };
    std::vector<std::thread> pool;
    for (size_t w = 1; w < parts; ++w) {
        const size_t b = count * w / parts, e = count * (w + 1) / parts;
        try {
            pool.emplace_back(run, b, e);
        } catch (const std::system_error&) {
            run(b, e);
        }
    }
    run(size_t(0), count / parts);
    for (std::thread& t : pool) t.join();
    if (error) std::rethrow_exception(error);
}

}  // namespace

void TriangleBvh::build(const std::vector<glm::dvec3>& positions, const std::vector<glm::uvec3>& triangles,
                        uint32_t threads) {
    m_nodes.clear();
    m_packets.clear();
    m_triangleIds.clear();
    m_slotOf.clear();
    m_depth = 0;
    m_coordinateScale = 0;
    const size_t count = triangles.size();
    if (count == 0 || count >= UINT32_MAX / 2) return;
    if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());

    for (const glm::dvec3& p : positions) {
        m_coordinateScale = std::max({m_coordinateScale, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    }
    // Keys: 30-bit Morton code of the triangle's box centre within the box of all vertices (10 bits
    // per axis), above the triangle index.
    glm::dvec3 lo(INFINITY), hi(-INFINITY);
    for (const glm::uvec3& t : triangles) {
        for (int k = 0; k < 3; ++k) {
            lo = glm::min(lo, positions[t[k]]);
            hi = glm::max(hi, positions[t[k]]);
        }
    }
    const glm::dvec3 extent = hi - lo;
    const double scale = 1023.0 / std::max({extent.x, extent.y, extent.z, 1e-300});
    std::vector<uint64_t> keys;
    resizeHuge(keys, count);
    parallelChunks(threads, count, [&](size_t b, size_t e) {
        for (size_t t = b; t < e; ++t) {
            const glm::dvec3& p0 = positions[triangles[t].x];
            const glm::dvec3& p1 = positions[triangles[t].y];
            const glm::dvec3& p2 = positions[triangles[t].z];
            const glm::dvec3 centre = 0.5 * (glm::min(glm::min(p0, p1), p2) + glm::max(glm::max(p0, p1), p2));
            const glm::dvec3 q = glm::clamp((centre - lo) * scale, 0.0, 1023.0);
            const uint64_t code =
                spreadBits(uint64_t(q.x)) | spreadBits(uint64_t(q.y)) << 1 | spreadBits(uint64_t(q.z)) << 2;
            keys[t] = code << 32 | t;
        }
    });
    radixSort(keys);

    // Tree (boxes from the stored float vertices, so they hold exactly what the queries test),
    // then the pancakes of every lane of up to kPancakeTriangles triangles, split over threads.
    std::vector<std::array<uint32_t, 8>> ranges;
    reserveHuge(m_nodes, count / 5 + 16);
    reserveHuge(ranges, count / 5 + 16);
    reserveHuge(m_packets, count / 3 + 16);
    reserveHuge(m_triangleIds, 4 * (count / 3 + 16));
    Builder4 builder{keys, positions, triangles, m_nodes, m_packets, m_triangleIds, ranges};
    float rootBox[6];
    builder.emit(0, static_cast<uint32_t>(count), 0, rootBox);
    m_depth = builder.maxDepth;
    keys = {};
    resizeHuge(m_slotOf, count, 0u);
    for (size_t slot = 0; slot < m_triangleIds.size(); ++slot) {
        if (m_triangleIds[slot] != UINT32_MAX) m_slotOf[m_triangleIds[slot]] = static_cast<uint32_t>(slot);
    }
    parallelChunks(threads, m_nodes.size(), [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            for (int c = 0; c < 4; ++c) {
                const uint32_t first = ranges[i][2 * c], end = ranges[i][2 * c + 1];
                if (end > first && end - first <= kPancakeTriangles / kMaxLeafSize) {
                    makePancake(m_nodes[i], c, m_packets.data(), m_triangleIds.data(), first, end);
                }
            }
        }
    });
}

void TriangleBvh::traverse(const glm::dvec3& p, double& bestSquared, ClosestHit& hit, bool& found,
                           BvhQueryStats* stats) const {
    const float px = static_cast<float>(p.x), py = static_cast<float>(p.y), pz = static_cast<float>(p.z);
    // Bounds are evaluated in float from a rounded query point: widen the pruning radius by a
    // margin far above that rounding so no child that could hold a closer triangle is skipped.
    const double slack =
        4e-6 * (m_coordinateScale + std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)})) + 1e-30;
    auto limitOf = [slack](double best2) {
        if (!(best2 < INFINITY)) return INFINITY;
        const double r = std::sqrt(best2) + slack;
        return static_cast<float>(r * r);
    };
    float limit = limitOf(bestSquared);

    struct Entry {
        uint32_t child, count;  // count 0: node index, else leaf triangles
        float d2;
    };
    Entry stack[kStackSize];
    int sp = 0;
    uint64_t visited = 0, tested = 0;
    // A leaf: all four triangles in float first; exact double distances for those that can win.
    auto testLeaf = [&](uint32_t packetIndex, uint32_t count) {
        const LeafPacket& packet = m_packets[packetIndex];
        float d2[4];
        leafDistances(packet, px, py, pz, d2);
        for (uint32_t l = 0; l < count; ++l) {
            if (d2[l] > limit) continue;  // a NaN (float overflow) gets the exact test
            const TriangleClosest c = closestPointOnTriangle(
                p, packetVertex(packet, l, 0), packetVertex(packet, l, 1), packetVertex(packet, l, 2));
            ++tested;
            if (c.distanceSquared < bestSquared || (!found && c.distanceSquared <= bestSquared)) {
                bestSquared = c.distanceSquared;
                found = true;
                hit.point = c.point;
                hit.feature = c.feature;
                hit.triangle = m_triangleIds[4 * size_t(packetIndex) + l];
                limit = limitOf(bestSquared);
            }
        }
    };

    uint32_t node = 0;
    for (;;) {
        const Node4& n = m_nodes[node];
        ++visited;
        float d2[4];
        boundDistances(n, px, py, pz, d2);
        // Used lanes whose bound is within the limit (a NaN bound, from float overflow, is visited).
        uint32_t mask = ((d2[0] > limit ? 0u : 1u) | (d2[1] > limit ? 0u : 2u) | (d2[2] > limit ? 0u : 4u) |
                         (d2[3] > limit ? 0u : 8u)) &
                        usedLanes(n);
        // Children within the limit, nearest first: the nearest is handled now, the others are
        // pushed farthest first.
        int nearest = -1;
        if (mask != 0) {
            if ((mask & (mask - 1)) == 0) {
                nearest = std::countr_zero(mask);
            } else {
                int order[4];
                int k = 0;
                for (; mask != 0; mask &= mask - 1) {
                    const int c = std::countr_zero(mask);
                    int j = k++;
                    while (j > 0 && d2[order[j - 1]] < d2[c]) {
                        order[j] = order[j - 1];
                        --j;
                    }
                    order[j] = c;  // descending distance
                }
                // Entries on the stack are pending siblings of the nodes on the current path (at
                // most 3 per level), so kStackSize bounds them (depth <= 62, see kStackSize); the
                // test keeps an overrun impossible regardless.
                if (sp + (k - 1) > kStackSize) throw std::logic_error("BVH traversal stack exhausted");
                for (int j = 0; j < k - 1; ++j)
                    stack[sp++] = Entry{n.child[order[j]], n.count[order[j]], d2[order[j]]};
                nearest = order[k - 1];
            }
        }
        if (nearest >= 0) {
            if (n.count[nearest] == 0) {
                node = n.child[nearest];
                continue;
            }
            testLeaf(n.child[nearest], n.count[nearest]);
        }
        // Next: pop the nearest entry still within the limit; leaves are tested on the way.
        bool descend = false;
        while (sp > 0) {
            const Entry e = stack[--sp];
            if (e.d2 > limit) continue;
            if (e.count != 0) {
                testLeaf(e.child, e.count);
                continue;
            }
            node = e.child;
            descend = true;
            break;
        }
        if (!descend) break;
    }
    if (found) hit.distance = std::sqrt(bestSquared);
    if (stats) {
        stats->nodesVisited += visited;
        stats->trianglesTested += tested;
    }
}

bool TriangleBvh::closest(const glm::dvec3& p, double maxDistance, ClosestHit& hit,
                          BvhQueryStats* stats) const {
    if (m_nodes.empty() || !(maxDistance >= 0)) return false;
    double best2 = maxDistance < INFINITY ? maxDistance * maxDistance : INFINITY;
    bool found = false;
    ClosestHit h;
    traverse(p, best2, h, found, stats);
    if (found) hit = h;
    return found;
}

ClosestHit TriangleBvh::closestSeeded(const glm::dvec3& p, uint32_t seed, BvhQueryStats* stats) const {
    ClosestHit hit;
    if (m_nodes.empty()) return hit;
    double best2 = INFINITY;
    bool found = false;
    if (seed < m_slotOf.size()) {
        const LeafPacket& packet = m_packets[m_slotOf[seed] / 4];
        const uint32_t l = m_slotOf[seed] % 4;
        const TriangleClosest c = closestPointOnTriangle(
            p, packetVertex(packet, l, 0), packetVertex(packet, l, 1), packetVertex(packet, l, 2));
        best2 = c.distanceSquared;
        hit.point = c.point;
        hit.feature = c.feature;
        hit.triangle = seed;
        found = true;
    }
    traverse(p, best2, hit, found, stats);
    hit.distance = std::sqrt(best2);
    return hit;
}

int TriangleBvh::signedCrossings(const glm::dvec3& origin, const glm::dvec3& direction) const {
    if (m_nodes.empty()) return 0;
    // Boxes in float, widened by a margin above the rounding of the float slab test (a box the
    // ray misses only by less than that is visited: costs time, never a crossing).
    const float margin = static_cast<float>(
        4e-6 * (m_coordinateScale + std::max({std::abs(origin.x), std::abs(origin.y), std::abs(origin.z)})) +
        1e-30);
    const float ox = static_cast<float>(origin.x), oy = static_cast<float>(origin.y),
                oz = static_cast<float>(origin.z);
    const float ix = static_cast<float>(1.0 / direction.x), iy = static_cast<float>(1.0 / direction.y),
                iz = static_cast<float>(1.0 / direction.z);
    auto slab = [](float lo, float hi, float o, float inv, float& t0, float& t1) {
        const float a = (lo - o) * inv, b = (hi - o) * inv;
        t0 = std::max(t0, std::min(a, b));
        t1 = std::min(t1, std::max(a, b));
    };
    int crossings = 0;
    uint32_t stack[kStackSize];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const Node4& n = m_nodes[stack[--sp]];
        for (int c = 0; c < 4; ++c) {
            if (n.child[c] == kEmptyLane) continue;
            float t0 = 0, t1 = INFINITY;
            slab(n.minX[c] - margin, n.maxX[c] + margin, ox, ix, t0, t1);
            slab(n.minY[c] - margin, n.maxY[c] + margin, oy, iy, t0, t1);
            slab(n.minZ[c] - margin, n.maxZ[c] + margin, oz, iz, t0, t1);
            if (!(t0 <= t1)) continue;
            if (n.count[c] == 0) {
                // At most 3 pending siblings per level plus this node's 4 children (see traverse).
                if (sp >= kStackSize) throw std::logic_error("BVH ray traversal stack exhausted");
                stack[sp++] = n.child[c];
                continue;
            }
            // Leaf: Moller-Trumbore in double for each triangle.
            const LeafPacket& t = m_packets[n.child[c]];
            for (uint32_t l = 0; l < n.count[c]; ++l) {
                const glm::dvec3 a = packetVertex(t, l, 0);
                const glm::dvec3 e1 = packetVertex(t, l, 1) - a, e2 = packetVertex(t, l, 2) - a;
                const glm::dvec3 q = glm::cross(direction, e2);
                const double det = glm::dot(e1, q);
                if (det == 0) continue;  // ray parallel to the triangle's plane
                const double inv = 1.0 / det;
                const glm::dvec3 s = origin - a;
                const double u = glm::dot(s, q) * inv;
                if (u < 0 || u > 1) continue;
                const glm::dvec3 r = glm::cross(s, e1);
                const double v = glm::dot(direction, r) * inv;
                if (v < 0 || u + v > 1) continue;
                if (glm::dot(e2, r) * inv <= 0) continue;  // behind the origin
                // det = -(e1 x e2) . direction: positive when the ray enters the front side.
                crossings += det > 0 ? -1 : 1;
            }
        }
    }
    return crossings;
}

}  // namespace penumbra::sdf
