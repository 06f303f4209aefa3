// Generalized winding number (exact and hierarchical) and ray parity. See winding.h.
//
// Tree: triangle centroids are sorted along a 30-bit Morton curve and split top-down at the highest
// differing code bit (each split halves an octree cell, so nodes stay compact and their expansion
// radii small), at the median once all codes in a range are equal. The splits are grouped into a
// 4-wide tree whose nodes store their four children side by side (structure of arrays), so a query
// tests four children at once with 4-wide float arithmetic. Per child: expansion centre
// (area-weighted centroid), (beta * radius)^2 with the radius measured exactly (farthest vertex),
// the area-weighted normal sum (order 1, the dipole) and the symmetric part of the first moment
// sum a n (x - c)^T (order 2); a separate array holds the children's boxes for ray traversal.
// Leaves hold up to kLeafSize triangles in a 4-wide block. Everything is stored as float in
// normalised coordinates (x - centre) / scale, the bounding box mapped into [-1, 1]^3: solid angles
// do not change under translation and uniform scaling, and floats keep their range whatever the
// mesh's units or position.
//
// fast(): a far child (|q - c| > beta * r) contributes its expansion, a near internal child is
// descended, a near leaf is evaluated exactly (Van Oosterom & Strackee solid angles, float, with an
// atan2 accurate to 2e-7 rad). exact() sums every triangle in double. parityInside(): majority of
// three rays, each counting crossings with a watertight ray/triangle test (Woop, Benthin, Wald 2013)
// in double on the stored float vertices, whose ties (a ray exactly through an edge or a vertex) are
// broken consistently between neighbouring triangles.
#include "engine/sdf/winding.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <numbers>

#include <glm/geometric.hpp>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#if defined(__SSE2__) || defined(_M_X64)
#include <emmintrin.h>
#define PENUMBRA_WINDING_SSE2 1
#endif

namespace penumbra::sdf {

namespace {

constexpr double kInv4Pi = 0.25 / std::numbers::pi;
constexpr uint32_t kLeafSize = 8;  // max triangles per leaf (a multiple of 4: 4-wide evaluation)
constexpr uint32_t kLeafBits = std::bit_width(kLeafSize - 1);  // leaf lanes: block << kLeafBits | count - 1
constexpr uint32_t kMaxSplitDepth = 96;  // Morton splits above, median splits below: depth < 96 + 32
constexpr uint32_t kStackSize = 512;     // > 3 * max depth + 1 (a node pushes at most 4, pops 1)
// Boxes are padded by this (normalised units) and rays start inside the padded root box, so the
// float slab test (error < 1e-6 there) never misses a box it should enter.
constexpr double kBoxPad = 4e-6;
constexpr size_t kMaxTriangles = size_t(1) << (32 - kLeafBits);  // block indices must fit

// ---------------------------------------------------------------------------------------------
// Four floats (SSE2 where available, plain arrays elsewhere). Masks are F4 with all bits set.

#if PENUMBRA_WINDING_SSE2
struct F4 {
    __m128 v;
    static F4 load(const float* p) { return {_mm_load_ps(p)}; }
    static F4 set(float x) { return {_mm_set1_ps(x)}; }
    static F4 zero() { return {_mm_setzero_ps()}; }
    friend F4 operator+(F4 a, F4 b) { return {_mm_add_ps(a.v, b.v)}; }
    friend F4 operator-(F4 a, F4 b) { return {_mm_sub_ps(a.v, b.v)}; }
    friend F4 operator*(F4 a, F4 b) { return {_mm_mul_ps(a.v, b.v)}; }
    friend F4 operator/(F4 a, F4 b) { return {_mm_div_ps(a.v, b.v)}; }
    friend F4 operator>(F4 a, F4 b) { return {_mm_cmpgt_ps(a.v, b.v)}; }
    friend F4 operator<(F4 a, F4 b) { return {_mm_cmplt_ps(a.v, b.v)}; }
    friend F4 operator&(F4 a, F4 b) { return {_mm_and_ps(a.v, b.v)}; }
    friend F4 operator^(F4 a, F4 b) { return {_mm_xor_ps(a.v, b.v)}; }
};
inline F4 sqrt(F4 a) { return {_mm_sqrt_ps(a.v)}; }
inline F4 min(F4 a, F4 b) { return {_mm_min_ps(a.v, b.v)}; }
inline F4 max(F4 a, F4 b) { return {_mm_max_ps(a.v, b.v)}; }
inline F4 select(F4 mask, F4 a, F4 b) {
    return {_mm_or_ps(_mm_and_ps(mask.v, a.v), _mm_andnot_ps(mask.v, b.v))};
}
inline F4 signBits(F4 a) { return {_mm_and_ps(a.v, _mm_set1_ps(-0.0f))}; }
inline F4 abs(F4 a) { return {_mm_andnot_ps(_mm_set1_ps(-0.0f), a.v)}; }
inline int moveMask(F4 m) { return _mm_movemask_ps(m.v); }
inline float maxLane(F4 a) {
    alignas(16) float t[4];
    _mm_store_ps(t, a.v);
    return std::max(std::max(t[0], t[1]), std::max(t[2], t[3]));
}
// All bits set in lanes [0, count).
inline F4 laneMask(uint32_t count) {
    return {_mm_castsi128_ps(_mm_cmpgt_epi32(_mm_set1_epi32(int(count)), _mm_set_epi32(3, 2, 1, 0)))};
}
inline float sum(F4 a) {
    alignas(16) float t[4];
    _mm_store_ps(t, a.v);
    return (t[0] + t[1]) + (t[2] + t[3]);
}
#else
struct F4 {
    float v[4];
    static F4 load(const float* p) { return {{p[0], p[1], p[2], p[3]}}; }
    static F4 set(float x) { return {{x, x, x, x}}; }
    static F4 zero() { return set(0.0f); }
    template <typename Op>
    static F4 map(F4 a, F4 b, Op op) {
        F4 r;
        for (int i = 0; i < 4; ++i) r.v[i] = op(a.v[i], b.v[i]);
        return r;
    }
    static float fromBits(uint32_t b) { return std::bit_cast<float>(b); }
    static uint32_t bits(float f) { return std::bit_cast<uint32_t>(f); }
    friend F4 operator+(F4 a, F4 b) {
        return map(a, b, [](float x, float y) { return x + y; });
    }
    friend F4 operator-(F4 a, F4 b) {
        return map(a, b, [](float x, float y) { return x - y; });
    }
    friend F4 operator*(F4 a, F4 b) {
        return map(a, b, [](float x, float y) { return x * y; });
    }
    friend F4 operator/(F4 a, F4 b) {
        return map(a, b, [](float x, float y) { return x / y; });
    }
    friend F4 operator>(F4 a, F4 b) {
        return map(a, b, [](float x, float y) { return fromBits(x > y ? ~0u : 0u); });
    }
    friend F4 operator<(F4 a, F4 b) {
        return map(a, b, [](float x, float y) { return fromBits(x < y ? ~0u : 0u); });
    }
    friend F4 operator&(F4 a, F4 b) {
        return map(a, b, [](float x, float y) { return fromBits(bits(x) & bits(y)); });
    }
    friend F4 operator^(F4 a, F4 b) {
        return map(a, b, [](float x, float y) { return fromBits(bits(x) ^ bits(y)); });
    }
};
inline F4 sqrt(F4 a) {
    return F4::map(a, a, [](float x, float) { return std::sqrt(x); });
}
inline F4 min(F4 a, F4 b) {
    return F4::map(a, b, [](float x, float y) { return x < y ? x : y; });
}
inline F4 max(F4 a, F4 b) {
    return F4::map(a, b, [](float x, float y) { return x > y ? x : y; });
}
inline F4 select(F4 mask, F4 a, F4 b) {
    F4 r;
    for (int i = 0; i < 4; ++i) r.v[i] = F4::bits(mask.v[i]) ? a.v[i] : b.v[i];
    return r;
}
inline F4 signBits(F4 a) { return a & F4::set(-0.0f); }
inline F4 abs(F4 a) {
    return F4::map(a, a, [](float x, float) { return std::fabs(x); });
}
inline int moveMask(F4 m) {
    int r = 0;
    for (int i = 0; i < 4; ++i) r |= int(F4::bits(m.v[i]) >> 31) << i;
    return r;
}
inline F4 laneMask(uint32_t count) {
    F4 r;
    for (uint32_t i = 0; i < 4; ++i) r.v[i] = F4::fromBits(i < count ? ~0u : 0u);
    return r;
}
inline float sum(F4 a) { return (a.v[0] + a.v[1]) + (a.v[2] + a.v[3]); }
inline float maxLane(F4 a) { return std::max(std::max(a.v[0], a.v[1]), std::max(a.v[2], a.v[3])); }
#endif

// atan2 for four lanes, |error| < 2e-7 rad: octant reduction to |t| <= tan(pi/8), then an odd
// polynomial (least-squares fit on Chebyshev nodes, 5e-9 approximation error). atan2(0, 0) = 0.
inline F4 atan2(F4 y, F4 x) {
    const F4 ax = abs(x), ay = abs(y);
    const F4 hi = max(ax, ay), lo = min(ax, ay);
    const F4 reduce =
        lo > hi * F4::set(0.41421356237309503f);  // t > tan(pi/8): use atan(t) = pi/4 + atan((t-1)/(t+1))
    const F4 num = select(reduce, lo - hi, lo);
    const F4 den = max(select(reduce, lo + hi, hi), F4::set(std::numeric_limits<float>::min()));
    const F4 t = num / den;
    const F4 t2 = t * t;
    F4 p = F4::set(0.07905854106557478f);
    p = p * t2 + F4::set(-0.13825642020989418f);
    p = p * t2 + F4::set(0.199720154060163f);
    p = p * t2 + F4::set(-0.33332761423570195f);
    F4 r = t + t * t2 * p + (reduce & F4::set(float(std::numbers::pi / 4)));
    r = select(ay > ax, F4::set(float(std::numbers::pi / 2)) - r, r);
    r = select(x < F4::zero(), F4::set(float(std::numbers::pi)) - r, r);
    return r ^ signBits(y);
}

// ---------------------------------------------------------------------------------------------
// Storage.

// Allocator for the large arrays: 2 MiB aligned and marked for transparent huge pages on Linux.
// First-touch page faults dominate building over large meshes otherwise (on the 2-core VM this
// project is measured on, a 4 KiB fault costs ~20 us: ~5 ms per MiB).
template <typename T>
struct LargeAllocator {
    using value_type = T;
    static constexpr size_t kHugePage = size_t(2) << 20;
    LargeAllocator() = default;
    template <typename U>
    LargeAllocator(const LargeAllocator<U>&) noexcept {}
    static bool huge(size_t n) { return n * sizeof(T) >= 2 * kHugePage; }
    T* allocate(size_t n) {
        if (n > std::numeric_limits<size_t>::max() / sizeof(T) - kHugePage) throw std::bad_alloc();
        if (!huge(n)) return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(alignof(T))));
        const size_t bytes = (n * sizeof(T) + kHugePage - 1) & ~(kHugePage - 1);
        void* p = std::aligned_alloc(kHugePage, bytes);
        if (p == nullptr) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
        madvise(p, bytes, MADV_HUGEPAGE);  // a hint: failure only costs speed
#endif
        return static_cast<T*>(p);
    }
    void deallocate(T* p, size_t n) noexcept {
        if (huge(n))
            std::free(p);
        else
            ::operator delete(p, std::align_val_t(alignof(T)));
    }
    template <typename U>
    bool operator==(const LargeAllocator<U>&) const noexcept {
        return true;
    }
};
template <typename T>
using LargeVector = std::vector<T, LargeAllocator<T>>;

// Four children side by side. A leaf lane refers to a TriBlock of 1..kLeafSize triangles.
struct alignas(64) Node4 {
    float cx[4], cy[4], cz[4], farR2[4];   // expansion centre c, (beta * radius)^2 (-1: empty lane)
    float nx[4], ny[4], nz[4], trace[4];   // sum a n (order 1, dipole); trace of S
    float sxx[4], syy[4], szz[4], sxy[4];  // S: symmetric part of sum a n (g - c)^T (order 2)
    float sxz[4], syz[4];
    uint32_t child[4];  // node index, or (block << kLeafBits | (triangles - 1)) for a leaf lane
    uint32_t leafMask;  // bit i: lane i is a leaf
    uint32_t lanes;     // number of used lanes (1..4)
};

// A leaf's triangles, normalised coordinates; unused lanes repeat the first vertex (see buildLeaf).
struct alignas(16) TriBlock {
    float ax[kLeafSize], ay[kLeafSize], az[kLeafSize], bx[kLeafSize], by[kLeafSize], bz[kLeafSize];
    float cx[kLeafSize], cy[kLeafSize], cz[kLeafSize];
};

// The four children's bounding boxes (ray traversal only), padded by kBoxPad.
struct alignas(16) Box4 {
    float lox[4], loy[4], loz[4], hix[4], hiy[4], hiz[4];
};

// The whole mesh's expansion: a query farther than this needs no traversal.
struct RootExpansion {
    double c[3] = {0, 0, 0};
    double farR2 = -1;
    double n[3] = {0, 0, 0};
    double trace = 0;
    double s[6] = {0, 0, 0, 0, 0, 0};  // xx yy zz xy xz yz
};

// Double-precision aggregate of a subtree (normalised coordinates), for building.
struct Aggregate {
    glm::dvec3 c{0}, n{0};
    glm::dvec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
    double m[9] = {};  // sum over triangles of area * normal (centroid - c)^T, row-major
    double area = 0;
    uint32_t blockBegin = 0, blockEnd = 0;  // the subtree's blocks (contiguous: built depth first)
};

struct ExpansionFloats {
    float c[3], farR2, n[3], trace, s[6];
};

inline double solidAngleHalf(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    // Van Oosterom & Strackee: tan(omega / 2) = det / denominator; returns omega / 2.
    const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
    const double det = glm::dot(a, glm::cross(b, c));
    const double den = la * lb * lc + glm::dot(a, b) * lc + glm::dot(b, c) * la + glm::dot(c, a) * lb;
    return std::atan2(det, den);
}

inline uint32_t spreadBits10(uint32_t x) {
    x &= 0x3ff;
    x = (x | x << 16) & 0x030000ff;
    x = (x | x << 8) & 0x0300f00f;
    x = (x | x << 4) & 0x030c30c3;
    x = (x | x << 2) & 0x09249249;
    return x;
}

// A usable triangle while building: Morton code of its centroid and its vertex indices (so the
// sorted order needs no lookup into the caller's triangle array).
struct SortEntry {
    uint32_t key;
    glm::uvec3 tri;
};

// LSD radix sort by key (30 bits): three passes of 10 bits.
void radixSort(LargeVector<SortEntry>& items) {
    constexpr int kBits = 10, kPasses = 3;
    const size_t n = items.size();
    LargeVector<SortEntry> other(n);
    std::vector<uint32_t> hist(size_t(kPasses) << kBits, 0);
    for (const SortEntry& e : items)
        for (int pass = 0; pass < kPasses; ++pass)
            ++hist[(size_t(pass) << kBits) + ((e.key >> (pass * kBits)) & 1023u)];
    for (int pass = 0; pass < kPasses; ++pass) {
        uint32_t* h = hist.data() + (size_t(pass) << kBits);
        uint32_t total = 0;
        for (uint32_t i = 0; i < (1u << kBits); ++i) {
            const uint32_t t = h[i];
            h[i] = total;
            total += t;
        }
        const int shift = pass * kBits;
        for (const SortEntry& e : items) other[h[(e.key >> shift) & 1023u]++] = e;
        items.swap(other);
    }
}

// ---------------------------------------------------------------------------------------------
// Ray parity.

// Precomputed state of one ray for the watertight ray/triangle test (Woop, Benthin, Wald 2013).
struct Ray {
    glm::dvec3 o, dir;
    int kx, ky, kz;
    double sx, sy, sz;
    F4 ox, oy, oz, idx, idy, idz;  // float origin and inverse direction, for the box test
};

Ray makeRay(const glm::dvec3& origin, const glm::dvec3& dir) {
    Ray r{};
    r.o = origin;
    r.dir = dir;
    int kz = 0;
    if (std::abs(dir.y) > std::abs(dir[kz])) kz = 1;
    if (std::abs(dir.z) > std::abs(dir[kz])) kz = 2;
    int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
    if (dir[kz] < 0) std::swap(kx, ky);  // keep the projected winding order
    r.kx = kx;
    r.ky = ky;
    r.kz = kz;
    r.sx = dir[kx] / dir[kz];
    r.sy = dir[ky] / dir[kz];
    r.sz = 1.0 / dir[kz];
    r.ox = F4::set(float(origin.x));
    r.oy = F4::set(float(origin.y));
    r.oz = F4::set(float(origin.z));
    // Zero components get a tiny stand-in: no 0 * inf in the slab test.
    auto inverse = [](double d) {
        return F4::set(float(1.0 / (std::abs(d) < 1e-20 ? std::copysign(1e-20, d) : d)));
    };
    r.idx = inverse(dir.x);
    r.idy = inverse(dir.y);
    r.idz = inverse(dir.z);
    return r;
}

// Lanes of a Box4 that the ray (t >= 0) enters.
inline int rayHitsBoxes(const Ray& r, const Box4& b) {
    const F4 tx0 = (F4::load(b.lox) - r.ox) * r.idx, tx1 = (F4::load(b.hix) - r.ox) * r.idx;
    const F4 ty0 = (F4::load(b.loy) - r.oy) * r.idy, ty1 = (F4::load(b.hiy) - r.oy) * r.idy;
    const F4 tz0 = (F4::load(b.loz) - r.oz) * r.idz, tz1 = (F4::load(b.hiz) - r.oz) * r.idz;
    const F4 tmin = max(max(min(tx0, tx1), min(ty0, ty1)), max(min(tz0, tz1), F4::zero()));
    const F4 tmax = min(min(max(tx0, tx1), max(ty0, ty1)), max(tz0, tz1));
    return ~moveMask(tmin > tmax) & 0xf;  // conservative: NaN counts as a hit
}

// Three fixed, irrational, mutually far-apart unit directions (not along axes or diagonals).
const std::array<glm::dvec3, 3> kRayDirections = {
    glm::normalize(glm::dvec3(1.0, 0.41421356237309515, 0.26794919243112270)),
    glm::normalize(glm::dvec3(-0.30901699437494745, 1.0, 0.58578643762690485)),
    glm::normalize(glm::dvec3(0.23606797749978970, -0.44721359549995794, -1.0)),
};

struct Vertex2 {
    float key[3];  // the stored vertex, for the canonical edge order
    double x, y;   // sheared and projected, relative to the ray origin
};

inline bool lexLess(const float* a, const float* b) {
    if (a[0] != b[0]) return a[0] < b[0];
    if (a[1] != b[1]) return a[1] < b[1];
    return a[2] < b[2];
}

// Edge function of the directed edge p->q at the projected ray origin, evaluated in a canonical
// vertex order so that two triangles sharing the edge get bit-identical values (up to sign),
// whatever the compiler does with the arithmetic.
inline double edgeFunction(const Vertex2& p, const Vertex2& q, bool& canonical) {
    canonical = !lexLess(q.key, p.key);
    if (canonical) return p.x * q.y - p.y * q.x;
    return -(q.x * p.y - q.y * p.x);
}

// Whether an edge whose line passes exactly through the ray still covers it: the ray is symbolically
// moved by (eps, eps^2) in the projected plane and the edge's inward normal decides. Triangles on
// opposite sides of a shared edge have opposite inward normals, so exactly one takes the hit.
inline bool tieIncluded(const Vertex2& p, const Vertex2& q, bool canonical, double orientation) {
    const Vertex2& a = canonical ? p : q;
    const Vertex2& b = canonical ? q : p;
    const double dx = b.x - a.x, dy = b.y - a.y;  // canonical direction: identical in neighbours
    const double s = canonical ? orientation : -orientation;
    const double nx = -dy * s, ny = dx * s;
    return nx > 0 || (nx == 0 && ny > 0);
}

// Whether the ray (t > 0) crosses the triangle (float vertices: the stored ones, identical for every
// triangle that shares a vertex).
bool rayCrosses(const Ray& r, const float (&v)[3][3]) {
    Vertex2 p[3];
    double z[3];
    for (int i = 0; i < 3; ++i) {
        const glm::dvec3 a = glm::dvec3(v[i][0], v[i][1], v[i][2]) - r.o;
        for (int k = 0; k < 3; ++k) p[i].key[k] = v[i][k];
        p[i].x = a[r.kx] - r.sx * a[r.kz];
        p[i].y = a[r.ky] - r.sy * a[r.kz];
        z[i] = r.sz * a[r.kz];
    }
    // e[i]: edge opposite vertex i, directed p[i+1] -> p[i+2]; proportional to barycentric i.
    double e[3];
    bool canonical[3];
    for (int i = 0; i < 3; ++i) e[i] = edgeFunction(p[(i + 1) % 3], p[(i + 2) % 3], canonical[i]);
    const double det = e[0] + e[1] + e[2];
    if (det == 0 || !std::isfinite(det)) return false;
    const double orientation = det > 0 ? 1.0 : -1.0;
    for (int i = 0; i < 3; ++i) {
        const double s = e[i] * orientation;
        if (s < 0) return false;
        if (s == 0 && !tieIncluded(p[(i + 1) % 3], p[(i + 2) % 3], canonical[i], orientation)) return false;
    }
    const double tScaled = e[0] * z[0] + e[1] * z[1] + e[2] * z[2];
    return tScaled * orientation > 0;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

struct WindingNumber::Impl {
    const std::vector<glm::dvec3>& positions;
    const std::vector<glm::uvec3>& triangles;
    double beta;
    glm::dvec3 centre{0};
    double invScale = 1;  // normalised = (x - centre) * invScale
    uint32_t count = 0;   // usable triangles
    LargeVector<Node4> nodes;
    LargeVector<Box4> boxes;
    LargeVector<TriBlock> blocks;
    glm::dvec3 rootLo{0}, rootHi{0};  // padded box of all triangles
    LargeVector<SortEntry> sorted;    // build only
    std::array<glm::dvec3, 3> rayDirections = kRayDirections;
    RootExpansion root;

    Impl(const std::vector<glm::dvec3>& p, const std::vector<glm::uvec3>& t, double b)
        : positions(p), triangles(t), beta(b) {}

    void build();
    uint32_t splitRange(uint32_t begin, uint32_t end) const;
    Aggregate buildLeaf(uint32_t first, uint32_t last, uint32_t& code);
    ExpansionFloats expansion(const Aggregate& a) const;
    uint32_t buildNode(uint32_t begin, uint32_t end, uint32_t depth, Aggregate& out);
    float nearBlock(const TriBlock& b, F4 qx, F4 qy, F4 qz) const;
    uint32_t countCrossings(const Ray& ray) const;
    uint32_t countCrossingsBruteForce(const Ray& ray) const;
};

void WindingNumber::Impl::build() {
    if (!(beta > 0) || !std::isfinite(beta)) beta = 2.0;
    // Usable triangles: indices in range and a finite, non-zero area (zero area adds nothing).
    const size_t nv = positions.size();
    if (triangles.size() >= kMaxTriangles) return;  // fast() and parityInside() fall back to brute force
    sorted.reserve(triangles.size());
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (size_t i = 0; i < triangles.size(); ++i) {
        const glm::uvec3 t = triangles[i];
        if (t.x >= nv || t.y >= nv || t.z >= nv) continue;
        const glm::dvec3 a = positions[t.x], b = positions[t.y], c = positions[t.z];
        const glm::dvec3 cr = glm::cross(b - a, c - a);
        const double area2 = glm::dot(cr, cr);
        if (!(area2 > 0) || !std::isfinite(area2)) continue;
        sorted.push_back({0, t});
        lo = glm::min(lo, glm::min(a, glm::min(b, c)));
        hi = glm::max(hi, glm::max(a, glm::max(b, c)));
    }
    count = uint32_t(sorted.size());
    if (count == 0) return;
    centre = (lo + hi) * 0.5;
    const glm::dvec3 half = (hi - lo) * 0.5;
    invScale = 1.0 / std::max({half.x, half.y, half.z});  // > 0: there is a triangle of non-zero area

    // Morton code of each centroid, 10 bits per axis.
    const glm::dvec3 scale = 1023.0 / glm::max(hi - lo, glm::dvec3(1e-300));
    for (SortEntry& entry : sorted) {
        const glm::uvec3 t = entry.tri;
        const glm::dvec3 g = (positions[t.x] + positions[t.y] + positions[t.z]) * (1.0 / 3.0);
        const glm::uvec3 u(glm::clamp((g - lo) * scale, 0.0, 1023.0));
        entry.key = spreadBits10(u.x) | spreadBits10(u.y) << 1 | spreadBits10(u.z) << 2;
    }
    radixSort(sorted);

    // Typical sizes (real meshes: ~6.3 triangles per leaf, ~3 lanes per node) with a margin; the
    // vectors grow if a mesh needs more.
    nodes.reserve(count / 8 + 1);
    boxes.reserve(count / 8 + 1);
    blocks.reserve(count / 4 + 1);
    Aggregate all;
    buildNode(0, count, 0, all);
    rootLo = all.lo - kBoxPad;
    rootHi = all.hi + kBoxPad;
    const ExpansionFloats e = expansion(all);
    for (int i = 0; i < 3; ++i) {
        root.c[i] = e.c[i];
        root.n[i] = e.n[i];
    }
    root.farR2 = e.farR2;
    root.trace = e.trace;
    for (int i = 0; i < 6; ++i) root.s[i] = e.s[i];
    sorted = {};
}

// Split point of the sorted triangle range [begin, end): the highest Morton bit that differs (which
// halves an octree cell), or the median when all codes are equal.
uint32_t WindingNumber::Impl::splitRange(uint32_t begin, uint32_t end) const {
    const uint32_t a = sorted[begin].key, b = sorted[end - 1].key;
    if (a == b) return begin + (end - begin) / 2;
    const int bit = 31 - std::countl_zero(a ^ b);
    const uint32_t target = (a & (~0u << bit)) | (1u << bit);
    return uint32_t(std::lower_bound(sorted.begin() + begin, sorted.begin() + end, target,
                                     [](const SortEntry& e, uint32_t key) { return e.key < key; }) -
                    sorted.begin());
}

// Copies triangles [first, last) of the sorted order into a new block and aggregates them, from the
// stored floats, so that the expansion describes exactly what the near field evaluates.
Aggregate WindingNumber::Impl::buildLeaf(uint32_t first, uint32_t last, uint32_t& code) {
    const uint32_t blockIndex = uint32_t(blocks.size());
    TriBlock& b = blocks.emplace_back();
    float* dst[3][3] = {{b.ax, b.ay, b.az}, {b.bx, b.by, b.bz}, {b.cx, b.cy, b.cz}};
    glm::dvec3 p[kLeafSize][3];
    glm::dvec3 an[kLeafSize];
    Aggregate a;
    glm::dvec3 weighted(0);
    const uint32_t n = last - first;
    for (uint32_t k = 0; k < n; ++k) {
        const glm::uvec3 t = sorted[first + k].tri;
        for (int v = 0; v < 3; ++v) {
            const glm::dvec3 rel = (positions[t[v]] - centre) * invScale;
            for (int i = 0; i < 3; ++i) {
                const float f = float(rel[i]);
                dst[v][i][k] = f;
                p[k][v][i] = f;
            }
        }
        an[k] = 0.5 * glm::cross(p[k][1] - p[k][0], p[k][2] - p[k][0]);
        const double area = glm::length(an[k]);
        a.n += an[k];
        a.area += area;
        weighted += area * (p[k][0] + p[k][1] + p[k][2]) * (1.0 / 3.0);
        a.lo = glm::min(a.lo, glm::min(p[k][0], glm::min(p[k][1], p[k][2])));
        a.hi = glm::max(a.hi, glm::max(p[k][0], glm::max(p[k][1], p[k][2])));
    }
    // Unused lanes: the degenerate triangle (v, v, v) on the first vertex. Its solid angle is exactly
    // 0 (b x c = 0), it adds no vertex to the radius, and rays never test it.
    for (uint32_t k = n; k < kLeafSize; ++k)
        for (int v = 0; v < 3; ++v)
            for (int i = 0; i < 3; ++i) dst[v][i][k] = dst[0][i][0];
    a.c = a.area > 0 ? weighted / a.area : (a.lo + a.hi) * 0.5;
    for (uint32_t k = 0; k < n; ++k) {
        const glm::dvec3 g = (p[k][0] + p[k][1] + p[k][2]) * (1.0 / 3.0) - a.c;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) a.m[3 * i + j] += an[k][i] * g[j];
    }
    a.blockBegin = blockIndex;
    a.blockEnd = blockIndex + 1;
    code = blockIndex << kLeafBits | (n - 1);
    return a;
}

// The float expansion data of a subtree. Its radius is measured exactly: the largest distance from
// the (float) centre to a stored vertex below, with a relative margin for the far test's rounding.
ExpansionFloats WindingNumber::Impl::expansion(const Aggregate& a) const {
    ExpansionFloats e{};
    for (int i = 0; i < 3; ++i) {
        e.c[i] = float(a.c[i]);
        e.n[i] = float(a.n[i]);
    }
    const F4 cx = F4::set(e.c[0]), cy = F4::set(e.c[1]), cz = F4::set(e.c[2]);
    F4 r2 = F4::zero();
    for (uint32_t bi = a.blockBegin; bi < a.blockEnd; ++bi) {
        const TriBlock& b = blocks[bi];
        const float* xs[3] = {b.ax, b.bx, b.cx};
        const float* ys[3] = {b.ay, b.by, b.cy};
        const float* zs[3] = {b.az, b.bz, b.cz};
        for (uint32_t h = 0; h < kLeafSize; h += 4)
            for (int v = 0; v < 3; ++v) {
                const F4 dx = F4::load(xs[v] + h) - cx, dy = F4::load(ys[v] + h) - cy,
                         dz = F4::load(zs[v] + h) - cz;
                r2 = max(r2, dx * dx + dy * dy + dz * dz);
            }
    }
    const double farR = beta * std::sqrt(double(maxLane(r2))) * (1.0 + 1e-5);
    e.farR2 = float(farR * farR);
    e.trace = float(a.m[0] + a.m[4] + a.m[8]);
    e.s[0] = float(a.m[0]);
    e.s[1] = float(a.m[4]);
    e.s[2] = float(a.m[8]);
    e.s[3] = float(0.5 * (a.m[1] + a.m[3]));
    e.s[4] = float(0.5 * (a.m[2] + a.m[6]));
    e.s[5] = float(0.5 * (a.m[5] + a.m[7]));
    return e;
}

uint32_t WindingNumber::Impl::buildNode(uint32_t begin, uint32_t end, uint32_t depth, Aggregate& out) {
    // Lanes: a range of at most 4 leaves' worth is cut into up to four leaves of consecutive
    // triangles (the root of a tiny mesh included); a larger one is split at Morton bits (the median
    // below a depth cap that bounds the traversal stack), always splitting the largest lane, until
    // there are four. A lane of at most kLeafSize triangles is a leaf. (Filling nodes and leaves
    // completely by cutting larger ranges into consecutive runs makes the tree 15 % smaller but
    // queries 15-25 % slower: Morton runs that cross cell boundaries are less compact.)
    struct Lane {
        uint32_t begin, end, depth;
    };
    std::array<Lane, 4> lanes;
    uint32_t laneCount = 0;
    const uint32_t n = end - begin;
    if (n <= 4 * kLeafSize) {
        const uint32_t leaves = (n + kLeafSize - 1) / kLeafSize;
        for (uint32_t i = 0; i < leaves; ++i)
            lanes[laneCount++] = {begin + n * i / leaves, begin + n * (i + 1) / leaves, depth + 1};
    } else {
        lanes[laneCount++] = {begin, end, depth};
        while (laneCount < 4) {
            uint32_t largest = 0;
            for (uint32_t i = 1; i < laneCount; ++i)
                if (lanes[i].end - lanes[i].begin > lanes[largest].end - lanes[largest].begin) largest = i;
            const Lane l = lanes[largest];
            if (l.end - l.begin <= kLeafSize) break;
            const uint32_t split =
                l.depth < kMaxSplitDepth ? splitRange(l.begin, l.end) : l.begin + (l.end - l.begin) / 2;
            lanes[largest] = {l.begin, split, l.depth + 1};
            lanes[laneCount++] = {split, l.end, l.depth + 1};
        }
    }

    const uint32_t index = uint32_t(nodes.size());
    nodes.emplace_back();
    boxes.emplace_back();
    std::array<Aggregate, 4> agg;
    std::array<uint32_t, 4> child{};
    uint32_t leafMask = 0;
    for (uint32_t i = 0; i < laneCount; ++i) {
        if (lanes[i].end - lanes[i].begin <= kLeafSize) {
            agg[i] = buildLeaf(lanes[i].begin, lanes[i].end, child[i]);
            leafMask |= 1u << i;
        } else {
            child[i] = buildNode(lanes[i].begin, lanes[i].end, lanes[i].depth, agg[i]);
        }
    }

    Node4& node = nodes[index];  // after the recursion: the vector may have grown
    Box4& box = boxes[index];
    for (uint32_t i = 0; i < 4; ++i) {
        if (i >= laneCount) {
            node.farR2[i] = -1;  // always "far"; masked out of the sum
            continue;
        }
        const ExpansionFloats e = expansion(agg[i]);
        node.cx[i] = e.c[0], node.cy[i] = e.c[1], node.cz[i] = e.c[2], node.farR2[i] = e.farR2;
        node.nx[i] = e.n[0], node.ny[i] = e.n[1], node.nz[i] = e.n[2], node.trace[i] = e.trace;
        node.sxx[i] = e.s[0], node.syy[i] = e.s[1], node.szz[i] = e.s[2];
        node.sxy[i] = e.s[3], node.sxz[i] = e.s[4], node.syz[i] = e.s[5];
        node.child[i] = child[i];
        // Padded float box (the pad is far larger than the float rounding of normalised values).
        const auto down = [](double v) { return float(v - kBoxPad); };
        const auto up = [](double v) { return float(v + kBoxPad); };
        box.lox[i] = down(agg[i].lo.x), box.loy[i] = down(agg[i].lo.y), box.loz[i] = down(agg[i].lo.z);
        box.hix[i] = up(agg[i].hi.x), box.hiy[i] = up(agg[i].hi.y), box.hiz[i] = up(agg[i].hi.z);
    }
    node.leafMask = leafMask;
    node.lanes = laneCount;

    // Aggregate of the whole node, about its own centre.
    Aggregate a;
    glm::dvec3 weighted(0);
    for (uint32_t i = 0; i < laneCount; ++i) {
        a.area += agg[i].area;
        a.n += agg[i].n;
        a.lo = glm::min(a.lo, agg[i].lo);
        a.hi = glm::max(a.hi, agg[i].hi);
        weighted += agg[i].c * agg[i].area;
    }
    a.c = a.area > 0 ? weighted / a.area : (a.lo + a.hi) * 0.5;
    for (uint32_t i = 0; i < laneCount; ++i) {
        const glm::dvec3 shift = agg[i].c - a.c;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) a.m[3 * r + c] += agg[i].m[3 * r + c] + agg[i].n[r] * shift[c];
    }
    a.blockBegin = agg[0].blockBegin;
    a.blockEnd = agg[laneCount - 1].blockEnd;
    out = a;
    return index;
}

// Sum of the half solid angles of a block's triangles seen from q, four lanes at once (unused lanes
// hold degenerate (v, v, v) triangles and add 0).
float WindingNumber::Impl::nearBlock(const TriBlock& b, F4 qx, F4 qy, F4 qz) const {
    F4 total = F4::zero();
    for (uint32_t h = 0; h < kLeafSize; h += 4) {
        const F4 ax = F4::load(b.ax + h) - qx, ay = F4::load(b.ay + h) - qy, az = F4::load(b.az + h) - qz;
        const F4 bx = F4::load(b.bx + h) - qx, by = F4::load(b.by + h) - qy, bz = F4::load(b.bz + h) - qz;
        const F4 cx = F4::load(b.cx + h) - qx, cy = F4::load(b.cy + h) - qy, cz = F4::load(b.cz + h) - qz;
        const F4 la = sqrt(ax * ax + ay * ay + az * az);
        const F4 lb = sqrt(bx * bx + by * by + bz * bz);
        const F4 lc = sqrt(cx * cx + cy * cy + cz * cz);
        const F4 det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx);
        const F4 ab = ax * bx + ay * by + az * bz;
        const F4 bc = bx * cx + by * cy + bz * cz;
        const F4 ca = cx * ax + cy * ay + cz * az;
        const F4 den = la * lb * lc + ab * lc + bc * la + ca * lb;
        total = total + atan2(det, den);
    }
    return sum(total);
}

uint32_t WindingNumber::Impl::countCrossings(const Ray& ray) const {
    uint32_t crossings = 0;
    uint32_t stack[kStackSize];
    uint32_t sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const uint32_t ni = stack[--sp];
        const Node4& node = nodes[ni];
        uint32_t hits = uint32_t(rayHitsBoxes(ray, boxes[ni])) & ((1u << node.lanes) - 1u);
        while (hits != 0) {
            const int lane = std::countr_zero(hits);
            hits &= hits - 1;
            const uint32_t child = node.child[lane];
            if ((node.leafMask >> lane & 1u) == 0) {
                stack[sp++] = child;
                continue;
            }
            const TriBlock& b = blocks[child >> kLeafBits];
            const uint32_t n = (child & (kLeafSize - 1)) + 1;
            for (uint32_t k = 0; k < n; ++k) {
                const float v[3][3] = {
                    {b.ax[k], b.ay[k], b.az[k]}, {b.bx[k], b.by[k], b.bz[k]}, {b.cx[k], b.cy[k], b.cz[k]}};
                crossings += rayCrosses(ray, v) ? 1u : 0u;
            }
        }
    }
    return crossings;
}

// Without a tree (more than kMaxTriangles triangles): every triangle.
uint32_t WindingNumber::Impl::countCrossingsBruteForce(const Ray& ray) const {
    uint32_t crossings = 0;
    const size_t nv = positions.size();
    for (const glm::uvec3& t : triangles) {
        if (t.x >= nv || t.y >= nv || t.z >= nv) continue;
        float v[3][3];
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) v[i][k] = float((positions[t[i]][k] - centre[k]) * invScale);
        crossings += rayCrosses(ray, v) ? 1u : 0u;
    }
    return crossings;
}

WindingNumber::WindingNumber(const std::vector<glm::dvec3>& positions,
                             const std::vector<glm::uvec3>& triangles, double beta)
    : m_impl(std::make_unique<Impl>(positions, triangles, beta)) {
    m_impl->build();
}

WindingNumber::~WindingNumber() = default;
WindingNumber::WindingNumber(WindingNumber&&) noexcept = default;
WindingNumber& WindingNumber::operator=(WindingNumber&&) noexcept = default;

double WindingNumber::exact(const glm::dvec3& p) const {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return std::numeric_limits<double>::quiet_NaN();
    const auto& pos = m_impl->positions;
    const size_t nv = pos.size();
    double sum = 0;
    for (const glm::uvec3& t : m_impl->triangles) {
        if (t.x >= nv || t.y >= nv || t.z >= nv) continue;
        // Zero area (tested on the mesh's own coordinates, as when building): no solid angle.
        const glm::dvec3 cr = glm::cross(pos[t.y] - pos[t.x], pos[t.z] - pos[t.x]);
        const double area2 = glm::dot(cr, cr);
        if (!(area2 > 0) || !std::isfinite(area2)) continue;
        sum += solidAngleHalf(pos[t.x] - p, pos[t.y] - p, pos[t.z] - p);
    }
    return sum * 2.0 * kInv4Pi;
}

double WindingNumber::fast(const glm::dvec3& p) const {
    const Impl& m = *m_impl;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return std::numeric_limits<double>::quiet_NaN();
    if (m.nodes.empty()) return m.triangles.size() >= kMaxTriangles ? exact(p) : 0.0;
    const glm::dvec3 qd = (p - m.centre) * m.invScale;

    // Far from the whole mesh: one expansion.
    {
        const RootExpansion& r = m.root;
        const double dx = r.c[0] - qd.x, dy = r.c[1] - qd.y, dz = r.c[2] - qd.z;
        const double r2 = dx * dx + dy * dy + dz * dz;
        if (r2 > r.farR2) {
            const double inv2 = 1.0 / r2, inv3 = inv2 / std::sqrt(r2);
            const double dipole = dx * r.n[0] + dy * r.n[1] + dz * r.n[2];
            const double dsd = dx * dx * r.s[0] + dy * dy * r.s[1] + dz * dz * r.s[2] +
                               2.0 * (dx * dy * r.s[3] + dx * dz * r.s[4] + dy * dz * r.s[5]);
            return (dipole + r.trace - 3.0 * dsd * inv2) * inv3 * kInv4Pi;
        }
    }

    const F4 qx = F4::set(float(qd.x)), qy = F4::set(float(qd.y)), qz = F4::set(float(qd.z));
    const F4 one = F4::set(1.0f), two = F4::set(2.0f), three = F4::set(3.0f);
    F4 farSum = F4::zero();
    float nearSum = 0;
    uint32_t stack[kStackSize];
    uint32_t sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const Node4& node = m.nodes[stack[--sp]];
        const F4 dx = F4::load(node.cx) - qx, dy = F4::load(node.cy) - qy, dz = F4::load(node.cz) - qz;
        const F4 dx2 = dx * dx, dy2 = dy * dy, dz2 = dz * dz;
        const F4 r2 = dx2 + dy2 + dz2;
        const F4 far = r2 > F4::load(node.farR2);  // empty lanes (farR2 = -1) count as far
        const int farBits = moveMask(far);
        if (farBits != 0) {
            // Orders 1 and 2 of sum_T a_T n_T . (x - q) / |x - q|^3 expanded about c, d = c - q:
            // (n . d + tr(S) - 3 d.S.d / |d|^2) / |d|^3. Near and empty lanes are masked out.
            const F4 inv = one / sqrt(r2);
            const F4 inv2 = inv * inv;
            const F4 inv3 = inv2 * inv;
            const F4 dipole = dx * F4::load(node.nx) + dy * F4::load(node.ny) + dz * F4::load(node.nz);
            const F4 dsd = dx2 * F4::load(node.sxx) + dy2 * F4::load(node.syy) + dz2 * F4::load(node.szz) +
                           two * (dx * dy * F4::load(node.sxy) + dx * dz * F4::load(node.sxz) +
                                  dy * dz * F4::load(node.syz));
            const F4 term = (dipole + F4::load(node.trace) - three * dsd * inv2) * inv3;
            farSum = farSum + (term & far & laneMask(node.lanes));
        }
        uint32_t nearBits = uint32_t(~farBits) & 0xfu;
        while (nearBits != 0) {
            const int lane = std::countr_zero(nearBits);
            nearBits &= nearBits - 1;
            if (node.leafMask >> lane & 1u)
                nearSum += m.nearBlock(m.blocks[node.child[lane] >> kLeafBits], qx, qy, qz);
            else
                stack[sp++] = node.child[lane];
        }
    }
    return (double(sum(farSum)) + 2.0 * double(nearSum)) * kInv4Pi;
}

void WindingNumber::setParityDirections(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const glm::dvec3 dirs[3] = {a, b, c};
    for (int i = 0; i < 3; ++i) {
        const double len = glm::length(dirs[i]);
        // A zero or non-finite direction keeps the default one.
        m_impl->rayDirections[i] = len > 0 && std::isfinite(len) ? dirs[i] / len : kRayDirections[i];
    }
}

bool WindingNumber::parityInside(const glm::dvec3& p) const {
    const Impl& m = *m_impl;
    const glm::dvec3 o = (p - m.centre) * m.invScale;
    if (!std::isfinite(o.x) || !std::isfinite(o.y) || !std::isfinite(o.z)) return false;
    int votes = 0;
    for (const glm::dvec3& dir : m.rayDirections) {
        if (m.nodes.empty()) {
            votes += int(m.countCrossingsBruteForce(makeRay(o, dir)) & 1u);
            continue;
        }
        // Start the ray where it enters the (padded) box of all triangles: nothing lies before that,
        // and the float box tests stay accurate.
        double t0 = 0, t1 = std::numeric_limits<double>::infinity();
        for (int i = 0; i < 3; ++i) {
            if (dir[i] == 0) {
                if (o[i] < m.rootLo[i] || o[i] > m.rootHi[i]) t0 = t1 + 1;
                continue;
            }
            double a = (m.rootLo[i] - o[i]) / dir[i], b = (m.rootHi[i] - o[i]) / dir[i];
            if (a > b) std::swap(a, b);
            t0 = std::max(t0, a);
            t1 = std::min(t1, b);
        }
        if (!(t0 <= t1)) continue;  // misses every triangle: no crossing
        votes += int(m.countCrossings(makeRay(o + dir * t0, dir)) & 1u);
    }
    return votes >= 2;
}

}  // namespace penumbra::sdf
