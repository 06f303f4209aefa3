#include "reference/reference.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <sstream>
#include <thread>

#include <embree3/rtcore.h>
#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include "engine/core/log.h"

namespace penumbra::reference {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct MeshRecord {
    std::vector<glm::dvec3> positions;  // world space
    std::vector<glm::dvec3> normals;    // world space, unit; empty: geometric normals
    std::vector<uint32_t> indices;
    int32_t id = -1;
};

struct Sphere {
    glm::dvec3 center;
    double radius;
    int32_t id;
};

struct Plane {
    glm::dvec3 normal;
    double offset;
    int32_t id;
};

// Smaller root in (tMin, tMax) of |o + t d - c|^2 = r^2 (stable quadratic).
bool intersectSphere(const Sphere& s, const glm::dvec3& o, const glm::dvec3& d, double tMin, double tMax,
                     double& t) {
    const glm::dvec3 oc = o - s.center;
    const double a = glm::dot(d, d);
    const double b = glm::dot(oc, d);
    const double c = glm::dot(oc, oc) - s.radius * s.radius;
    const double disc = b * b - a * c;
    if (disc < 0.0 || a <= 0.0) return false;
    const double q = -(b + std::copysign(std::sqrt(disc), b));
    double t0 = q / a, t1 = q != 0.0 ? c / q : t0;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > tMin && t0 < tMax) {
        t = t0;
        return true;
    }
    if (t1 > tMin && t1 < tMax) {
        t = t1;
        return true;
    }
    return false;
}

bool intersectPlane(const Plane& p, const glm::dvec3& o, const glm::dvec3& d, double tMin, double tMax,
                    double& t) {
    const double denom = glm::dot(p.normal, d);
    if (denom == 0.0) return false;
    const double tt = (p.offset - glm::dot(p.normal, o)) / denom;
    if (!(tt > tMin && tt < tMax)) return false;
    t = tt;
    return true;
}

// Orthonormal basis around unit n (Duff et al. 2017).
void basis(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double bb = n.x * n.y * a;
    t = glm::dvec3(1.0 + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    b = glm::dvec3(bb, sign + n.y * n.y * a, -n.y);
}

uint64_t splitmix64(uint64_t& state) {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// PCG32 (O'Neill), uniform doubles in [0, 1).
class Rng {
public:
    explicit Rng(uint64_t seed) {
        uint64_t s = seed;
        m_state = splitmix64(s);
        m_inc = splitmix64(s) | 1u;
    }
    uint32_t next() {
        const uint64_t old = m_state;
        m_state = old * 6364136223846793005ull + m_inc;
        const uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        const uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
    }
    double uniform() { return double(next()) * (1.0 / 4294967296.0); }

private:
    uint64_t m_state = 0, m_inc = 1;
};

// Calls f(u1, u2) for each cell of a jittered k x k grid (k * k = samples).
template <class F>
void forEachStratum(uint32_t samples, uint64_t seed, F&& f) {
    const uint32_t k = uint32_t(std::lround(std::sqrt(double(samples))));
    Rng rng(seed);
    for (uint32_t i = 0; i < k; ++i)
        for (uint32_t j = 0; j < k; ++j) {
            const double u1 = (i + rng.uniform()) / k;
            const double u2 = (j + rng.uniform()) / k;
            f(u1, u2);
        }
}

Estimate bernoulli(uint32_t unoccluded, uint32_t samples) {
    Estimate e;
    e.samples = samples;
    e.value = double(unoccluded) / double(samples);
    e.stdError = std::sqrt(std::max(0.0, e.value * (1.0 - e.value)) / double(samples));
    return e;
}

bool finiteMat(const glm::dmat4& m) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r])) return false;
    return true;
}

double maxAbs(const glm::dvec3& p) { return std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}); }

// ---- SDF objects (docs/ACCURACY.md, "SDF objects") --------------------------------------------------

// A shape program or a field in its own frame ("local"), placed by an affine matrix. Rays are
// transformed into the local frame (origin by the inverse matrix, direction by its linear part),
// which keeps the ray parameter t: hits are found there in double precision.
struct SdfObject {
    bool isField = false;
    sdf::ShapeProgram program;                   // shape program
    std::shared_ptr<const sdf::PsdfAsset> grid;  // field (a copy)
    std::unique_ptr<sdf::SdfSampler> sampler;    // field: normals
    glm::dmat4 toLocal{1.0};
    glm::dmat3 normalMatrix{1.0};         // inverse transpose of the model's linear part
    glm::dvec3 boxMin{0.0}, boxMax{0.0};  // local: padded program bounds / box of voxel centres
    double scale = 1.0;                   // local length scale of the tolerances
    int32_t id = -1;
    uint32_t mask = 0;
};

struct SdfCounters {
    std::atomic<uint64_t> rays{0}, iterations{0}, unconverged{0};
};

// Clips o + t d to the box [lo, hi] (infinite sides allowed): narrows [t0, t1]; false when empty.
bool clipToBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi,
               double& t0, double& t1) {
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < lo[a] || o[a] > hi[a]) return false;
            continue;
        }
        double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    return t0 <= t1;
}

// Bisects the bracket [a, b] (f(a), f(b) of opposite signs) to kSdfTolerance relative in t.
template <class F>
double bisect(F&& f, double a, double b, double fa) {
    for (int i = 0; i < 256 && b - a > kSdfTolerance * std::max(std::abs(a), std::abs(b)); ++i) {
        const double m = 0.5 * (a + b);
        if (!(m > a && m < b)) break;
        const double fm = f(m);
        if (fm == 0.0) return m;
        if ((fm > 0.0) == (fa > 0.0)) {
            a = m;
            fa = fm;
        } else {
            b = m;
        }
    }
    return 0.5 * (a + b);
}

// First root of a shape program along the local ray in (tMin, tMax): sphere tracing (the program
// never overestimates the distance, so a step of |d| / |dir| never crosses the surface) until
// |d| < tolerance or a sign change, whose bracket is bisected.
bool intersectProgram(const SdfObject& obj, const glm::dvec3& o, const glm::dvec3& d, double tMin,
                      double tMax, double& tHit, SdfCounters& counters) {
    double t0 = tMin, t1 = tMax;
    if (!clipToBox(o, d, obj.boxMin, obj.boxMax, t0, t1)) return false;
    const double speed = glm::length(d);
    if (!(speed > 0.0) || !std::isfinite(t0)) return false;
    ++counters.rays;
    auto f = [&](double t) { return sdf::evaluateShapeProgram(obj.program, o + t * d); };
    auto tolerance = [&](double t) { return kSdfTolerance * std::max(obj.scale, maxAbs(o + t * d)); };
    double t = t0, ft = f(t);
    if (std::abs(ft) < tolerance(t) && t > tMin) {
        tHit = t;
        return true;
    }
    uint32_t it = 0;
    bool hit = false;
    for (; it < kSdfMaxIterations; ++it) {
        const double tn = t + std::max(std::abs(ft), tolerance(t)) / speed;
        if (!(tn <= t1)) break;  // left the bounds (or tMax) without a root
        const double fn = f(tn);
        if (fn == 0.0) {
            tHit = tn;
            hit = true;
            break;
        }
        if ((fn > 0.0) != (ft > 0.0)) {
            tHit = bisect(f, t, tn, ft);
            hit = true;
            break;
        }
        if (std::abs(fn) < tolerance(tn)) {
            // Within the tolerance of the surface: a crossing is just ahead unless the ray grazes it.
            // Steps doubling from |d| / |dir| bracket it (they go at most twice as far as the root,
            // and no further than 1e-6 * scale), and the bracket is bisected; without a crossing
            // (a grazing ray) the hit is tn.
            tHit = tn;
            hit = true;
            double a = tn, fa = fn, step = std::max(std::abs(fn), 1e-3 * tolerance(tn)) / speed;
            const double limit = tn + 1e-6 * std::max(obj.scale, maxAbs(o + tn * d)) / speed;
            for (int k = 0; k < 64 && a + step <= std::min(t1, limit); ++k, step *= 2.0) {
                const double b = a + step, fb = f(b);
                if (fb == 0.0) {
                    tHit = b;
                    break;
                }
                if ((fb > 0.0) != (fa > 0.0)) {
                    tHit = bisect(f, a, b, fa);
                    break;
                }
                a = b;
                fa = fb;
            }
            break;
        }
        t = tn;
        ft = fn;
    }
    counters.iterations += it + 1;
    if (it == kSdfMaxIterations) ++counters.unconverged;
    return hit;
}

// The field's interpolant in grid coordinates g (voxel centre (i, j, k) at g = (i, j, k)) inside the
// cell with lower corner c: nested lerps as in sdf::SdfSampler::trilinear.
struct FieldCell {
    double v[8];  // corner values, index x + 2 y + 4 z
    double eval(const glm::dvec3& u) const {
        const double c00 = v[0] * (1 - u.x) + v[1] * u.x, c10 = v[2] * (1 - u.x) + v[3] * u.x;
        const double c01 = v[4] * (1 - u.x) + v[5] * u.x, c11 = v[6] * (1 - u.x) + v[7] * u.x;
        const double c0 = c00 * (1 - u.y) + c10 * u.y, c1 = c01 * (1 - u.y) + c11 * u.y;
        return c0 * (1 - u.z) + c1 * u.z;
    }
};

// First root of a field's trilinear interpolant along the local ray in (tMin, tMax): a 3D DDA over
// the cells between voxel centres; in a cell whose corners change sign the interpolant along the
// ray is a cubic, split at its turning points into monotone pieces whose sign changes are bisected.
bool intersectField(const SdfObject& obj, const glm::dvec3& o, const glm::dvec3& d, double tMin, double tMax,
                    double& tHit, SdfCounters& counters) {
    const sdf::SdfGrid& g = obj.grid->grid;
    const glm::dvec3 og = (o - g.origin) / g.voxelSize - 0.5, dg = d / g.voxelSize;
    const glm::dvec3 hiG = glm::dvec3(g.dims) - 1.0;
    double t0 = tMin, t1 = tMax;
    if (!clipToBox(og, dg, glm::dvec3(0.0), hiG, t0, t1) || !std::isfinite(t0)) return false;
    ++counters.rays;
    auto value = [&](uint32_t i, uint32_t j, uint32_t k) { return double(g.distances[g.index(i, j, k)]); };
    glm::ivec3 cell, stepDir;
    glm::dvec3 tNext, tDelta;
    const glm::dvec3 start = og + t0 * dg;
    for (int a = 0; a < 3; ++a) {
        const int last = int(g.dims[a]) - 2;
        cell[a] = std::clamp(int(std::floor(start[a])), 0, last);
        if (dg[a] > 0.0) {
            stepDir[a] = 1;
            tNext[a] = (double(cell[a] + 1) - og[a]) / dg[a];
            tDelta[a] = 1.0 / dg[a];
        } else if (dg[a] < 0.0) {
            stepDir[a] = -1;
            tNext[a] = (double(cell[a]) - og[a]) / dg[a];
            tDelta[a] = -1.0 / dg[a];
        } else {
            stepDir[a] = 0;
            tNext[a] = kInf;
            tDelta[a] = kInf;
        }
    }
    bool first = true;
    uint64_t cells = 0;
    double ts = t0;
    while (ts <= t1) {
        ++cells;
        const double te = std::min({tNext.x, tNext.y, tNext.z, t1});
        FieldCell c;
        double lo = kInf, hi = -kInf;
        for (int k = 0; k < 8; ++k) {
            c.v[k] = value(uint32_t(cell.x + (k & 1)), uint32_t(cell.y + ((k >> 1) & 1)),
                           uint32_t(cell.z + ((k >> 2) & 1)));
            lo = std::min(lo, c.v[k]);
            hi = std::max(hi, c.v[k]);
        }
        const glm::dvec3 base(cell);
        auto f = [&](double t) { return c.eval(og + t * dg - base); };
        if (first) {
            first = false;
            // Entering the box inside the solid: the box clips it, the hit is the entry point.
            if (t0 > tMin && f(t0) < 0.0) {
                tHit = t0;
                counters.iterations += cells;
                return true;
            }
        }
        if (lo <= 0.0 && hi >= 0.0) {
            // The cubic k0 + k1 t + k2 t^2 + k3 t^3 along the ray; its turning points split [ts, te].
            const glm::dvec3 u0 = og - base;
            double k[4] = {0, 0, 0, 0};
            for (int n = 0; n < 8; ++n) {
                double a0[3], a1[3];
                for (int a = 0; a < 3; ++a) {
                    const bool upper = (n >> a) & 1;
                    a0[a] = upper ? u0[a] : 1.0 - u0[a];
                    a1[a] = upper ? dg[a] : -dg[a];
                }
                k[0] += c.v[n] * a0[0] * a0[1] * a0[2];
                k[1] += c.v[n] * (a1[0] * a0[1] * a0[2] + a0[0] * a1[1] * a0[2] + a0[0] * a0[1] * a1[2]);
                k[2] += c.v[n] * (a1[0] * a1[1] * a0[2] + a1[0] * a0[1] * a1[2] + a0[0] * a1[1] * a1[2]);
                k[3] += c.v[n] * a1[0] * a1[1] * a1[2];
            }
            double cuts[4] = {ts, te, te, te};
            int nCuts = 1;
            // 3 k3 t^2 + 2 k2 t + k1 = 0 (stable quadratic; linear when k3 = 0)
            const double qa = 3.0 * k[3], qb = 2.0 * k[2], qc = k[1];
            double r[2];
            int nr = 0;
            if (qa != 0.0) {
                const double disc = qb * qb - 4.0 * qa * qc;
                if (disc >= 0.0) {
                    const double q = -0.5 * (qb + std::copysign(std::sqrt(disc), qb));
                    if (q != 0.0) {
                        r[nr++] = q / qa;
                        r[nr++] = qc / q;
                    } else {
                        r[nr++] = 0.0;
                    }
                }
            } else if (qb != 0.0) {
                r[nr++] = -qc / qb;
            }
            if (nr == 2 && r[0] > r[1]) std::swap(r[0], r[1]);
            for (int i = 0; i < nr; ++i)
                if (r[i] > ts && r[i] < te) cuts[nCuts++] = r[i];
            cuts[nCuts++] = te;
            double a = cuts[0], fa = f(a);
            for (int i = 1; i < nCuts; ++i) {
                const double b = cuts[i], fb = f(b);
                if (fa == 0.0 && a > tMin) {
                    tHit = a;
                    counters.iterations += cells;
                    return true;
                }
                if ((fa > 0.0) != (fb > 0.0) && fa != 0.0) {
                    tHit = fb == 0.0 ? b : bisect(f, a, b, fa);
                    counters.iterations += cells;
                    return true;
                }
                a = b;
                fa = fb;
            }
        }
        // Next cell.
        if (te >= t1) break;
        int axis = 0;
        if (tNext.y < tNext[axis]) axis = 1;
        if (tNext.z < tNext[axis]) axis = 2;
        cell[axis] += stepDir[axis];
        if (cell[axis] < 0 || cell[axis] > int(g.dims[axis]) - 2) break;
        tNext[axis] += tDelta[axis];
        ts = te;
    }
    counters.iterations += cells;
    return false;
}

bool intersectSdf(const SdfObject& obj, const glm::dvec3& origin, const glm::dvec3& dir, double tMin,
                  double tMax, double& t, SdfCounters& counters) {
    const glm::dvec3 o = glm::dvec3(obj.toLocal * glm::dvec4(origin, 1.0));
    const glm::dvec3 d = glm::dmat3(obj.toLocal) * dir;
    return obj.isField ? intersectField(obj, o, d, tMin, tMax, t, counters)
                       : intersectProgram(obj, o, d, tMin, tMax, t, counters);
}

// World-space unit normal at local point p: the central-difference gradient of the program or of
// the field's interpolant, by the inverse transpose.
glm::dvec3 sdfNormal(const SdfObject& obj, const glm::dvec3& p) {
    const double h = obj.isField ? 1e-6 * obj.grid->grid.voxelSize : 1e-7 * std::max(obj.scale, maxAbs(p));
    auto f = [&](const glm::dvec3& q) {
        return obj.isField ? obj.sampler->trilinear(q) : sdf::evaluateShapeProgram(obj.program, q);
    };
    glm::dvec3 grad;
    for (int a = 0; a < 3; ++a) {
        glm::dvec3 e(0.0);
        e[a] = h;
        grad[a] = (f(p + e) - f(p - e)) / (2.0 * h);
    }
    const glm::dvec3 n = obj.normalMatrix * grad;
    const double len = glm::length(n);
    return len > 0.0 && std::isfinite(len) ? n / len : glm::dvec3(0.0, 1.0, 0.0);
}

}  // namespace

// ---- scene ----------------------------------------------------------------------------------------

struct ReferenceScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<MeshRecord> meshes;  // indexed by Embree geometry id
    std::vector<Sphere> spheres;
    std::vector<Plane> planes;
    std::vector<std::unique_ptr<SdfObject>> sdfs;
    mutable SdfCounters sdfCounters;
    glm::dvec3 lo{kInf}, hi{-kInf};
    double extent = 1.0;
    bool committed = false;

    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
    void grow(const glm::dvec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
};

ReferenceScene::ReferenceScene() : m_impl(std::make_unique<Impl>()) {}
ReferenceScene::~ReferenceScene() = default;

std::unique_ptr<ReferenceScene> ReferenceScene::create(std::string& error) {
    std::unique_ptr<ReferenceScene> s(new ReferenceScene());
    s->m_impl->device = rtcNewDevice(nullptr);
    if (!s->m_impl->device) {
        error = fmt::format("Embree: cannot create a device (error {})", int(rtcGetDeviceError(nullptr)));
        return nullptr;
    }
    rtcSetDeviceErrorFunction(
        s->m_impl->device,
        [](void*, RTCError code, const char* message) {
            log::error("Embree error {}: {}", int(code), message ? message : "");
        },
        nullptr);
    s->m_impl->scene = rtcNewScene(s->m_impl->device);
    rtcSetSceneBuildQuality(s->m_impl->scene, RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(s->m_impl->scene, RTC_SCENE_FLAG_ROBUST);
    return s;
}

bool ReferenceScene::addMesh(const assets::MeshData& mesh, const glm::dmat4& model, int32_t id, uint32_t mask,
                             std::string& error) {
    Impl& m = *m_impl;
    if (m.committed) {
        error = "reference scene: addMesh after commit";
        return false;
    }
    if (mesh.indices.size() % 3 != 0 || !finiteMat(model)) {
        error = fmt::format(
            "reference scene: mesh of id {}: {}", id,
            mesh.indices.size() % 3 ? "index count is not a multiple of 3" : "transform is not finite");
        return false;
    }
    for (uint32_t i : mesh.indices)
        if (i >= mesh.positions.size()) {
            error = fmt::format("reference scene: mesh of id {}: index {} out of range", id, i);
            return false;
        }
    if (mesh.indices.empty()) return true;
    MeshRecord rec;
    rec.id = id;
    rec.indices = mesh.indices;
    rec.positions.reserve(mesh.positions.size());
    for (const glm::vec3& p : mesh.positions) {
        const glm::dvec3 w = glm::dvec3(model * glm::dvec4(glm::dvec3(p), 1.0));
        if (!std::isfinite(w.x) || !std::isfinite(w.y) || !std::isfinite(w.z)) {
            error = fmt::format("reference scene: mesh of id {}: a position is not finite", id);
            return false;
        }
        rec.positions.push_back(w);
        m.grow(w);
    }
    if (mesh.normals.size() == mesh.positions.size()) {
        const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(glm::dmat3(model)));
        rec.normals.reserve(mesh.normals.size());
        for (const glm::vec3& n : mesh.normals) {
            const glm::dvec3 w = normalMatrix * glm::dvec3(n);
            const double len = glm::length(w);
            rec.normals.push_back(len > 0.0 && std::isfinite(len) ? w / len : glm::dvec3(0.0));
        }
    }
    RTCGeometry geom = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), rec.positions.size()));
    auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), rec.indices.size() / 3));
    if (!v || !idx) {
        rtcReleaseGeometry(geom);
        error = "reference scene: Embree could not allocate a mesh buffer";
        return false;
    }
    for (size_t i = 0; i < rec.positions.size(); ++i) {
        v[3 * i + 0] = float(rec.positions[i].x);
        v[3 * i + 1] = float(rec.positions[i].y);
        v[3 * i + 2] = float(rec.positions[i].z);
    }
    std::copy(rec.indices.begin(), rec.indices.end(), idx);
    // Embree is built with ray masks: geometry is hit only by rays sharing a bit with its mask.
    rtcSetGeometryMask(geom, mask);
    rtcCommitGeometry(geom);
    const unsigned geomId = rtcAttachGeometry(m.scene, geom);
    rtcReleaseGeometry(geom);
    if (m.meshes.size() <= geomId) m.meshes.resize(geomId + 1);
    m.meshes[geomId] = std::move(rec);
    return true;
}

void ReferenceScene::addSphere(const glm::dvec3& center, double radius, int32_t id) {
    m_impl->spheres.push_back({center, radius, id});
    m_impl->grow(center - glm::dvec3(radius));
    m_impl->grow(center + glm::dvec3(radius));
}

void ReferenceScene::addPlane(const glm::dvec3& normal, double offset, int32_t id) {
    m_impl->planes.push_back({glm::normalize(normal), offset, id});
}

namespace {
// Places an SDF object: the inverse and normal matrices; false when `model` is not invertible.
bool placeSdf(SdfObject& obj, const glm::dmat4& model, int32_t id, uint32_t mask, const char* what,
              std::string& error) {
    const glm::dmat3 linear(model);
    const double det = glm::determinant(linear);
    const double norm = std::max({glm::length(linear[0]), glm::length(linear[1]), glm::length(linear[2])});
    if (!finiteMat(model) || !(std::abs(det) > 1e-300) || !(std::abs(det) > 1e-12 * norm * norm * norm)) {
        error =
            fmt::format("reference scene: {} of id {}: the transform is not finite and invertible", what, id);
        return false;
    }
    obj.toLocal = glm::inverse(model);
    obj.normalMatrix = glm::transpose(glm::inverse(linear));
    obj.id = id;
    obj.mask = mask;
    return true;
}
}  // namespace

bool ReferenceScene::addShapeProgram(const sdf::ShapeProgram& program, const glm::dmat4& model, int32_t id,
                                     uint32_t mask, std::string& error) {
    Impl& m = *m_impl;
    if (m.committed) {
        error = "reference scene: addShapeProgram after commit";
        return false;
    }
    std::string why;
    if (program.records.empty() || !sdf::validateShapeProgram(program.records, why)) {
        error = fmt::format("reference scene: shape program of id {}: {}", id, why.empty() ? "empty" : why);
        return false;
    }
    auto obj = std::make_unique<SdfObject>();
    if (!placeSdf(*obj, model, id, mask, "shape program", error)) return false;
    obj->program = program;
    // The program's bounds hold the solid; padded so that a root on a side is inside. The scale of
    // the tolerances is the largest finite extent (1 when none is finite).
    const sdf::ShapeBounds& b = program.bounds;
    double scale = 0.0;
    for (int a = 0; a < 3; ++a) {
        if (std::isfinite(b.min[a])) scale = std::max(scale, std::abs(b.min[a]));
        if (std::isfinite(b.max[a])) scale = std::max(scale, std::abs(b.max[a]));
    }
    obj->scale = scale > 0.0 ? scale : 1.0;
    const double pad = 1e-6 * obj->scale;
    obj->boxMin = b.min - pad;
    obj->boxMax = b.max + pad;
    if (b.finite()) {
        for (int c = 0; c < 8; ++c) {
            const glm::dvec3 corner((c & 1) ? b.max.x : b.min.x, (c & 2) ? b.max.y : b.min.y,
                                    (c & 4) ? b.max.z : b.min.z);
            m.grow(glm::dvec3(model * glm::dvec4(corner, 1.0)));
        }
    }
    m.sdfs.push_back(std::move(obj));
    return true;
}

bool ReferenceScene::addSdfField(const sdf::PsdfAsset& field, const glm::dmat4& model, int32_t id,
                                 uint32_t mask, std::string& error) {
    Impl& m = *m_impl;
    if (m.committed) {
        error = "reference scene: addSdfField after commit";
        return false;
    }
    const sdf::SdfGrid& g = field.grid;
    if (g.dims.x < 2 || g.dims.y < 2 || g.dims.z < 2 ||
        g.distances.size() != size_t(g.dims.x) * g.dims.y * g.dims.z || !(g.voxelSize > 0.0)) {
        error = fmt::format("reference scene: field of id {}: needs at least 2 voxels per axis ({}x{}x{})",
                            id, g.dims.x, g.dims.y, g.dims.z);
        return false;
    }
    auto obj = std::make_unique<SdfObject>();
    if (!placeSdf(*obj, model, id, mask, "field", error)) return false;
    obj->isField = true;
    obj->grid = std::make_shared<const sdf::PsdfAsset>(field);
    obj->sampler = std::make_unique<sdf::SdfSampler>(*obj->grid);
    obj->boxMin = g.voxelCenter(0, 0, 0);
    obj->boxMax = g.voxelCenter(g.dims.x - 1, g.dims.y - 1, g.dims.z - 1);
    obj->scale = glm::length(obj->boxMax - obj->boxMin);
    for (int c = 0; c < 8; ++c) {
        const glm::dvec3 corner((c & 1) ? obj->boxMax.x : obj->boxMin.x,
                                (c & 2) ? obj->boxMax.y : obj->boxMin.y,
                                (c & 4) ? obj->boxMax.z : obj->boxMin.z);
        m.grow(glm::dvec3(model * glm::dvec4(corner, 1.0)));
    }
    m.sdfs.push_back(std::move(obj));
    return true;
}

ReferenceScene::SdfStats ReferenceScene::sdfStats() const {
    const SdfCounters& c = m_impl->sdfCounters;
    return {c.rays.load(), c.iterations.load(), c.unconverged.load()};
}

void ReferenceScene::resetSdfStats() {
    SdfCounters& c = m_impl->sdfCounters;
    c.rays = 0;
    c.iterations = 0;
    c.unconverged = 0;
}

void ReferenceScene::addLight(const ReferenceLight& light) { m_lights.push_back(light); }

bool ReferenceScene::commit(std::string& error) {
    Impl& m = *m_impl;
    rtcCommitScene(m.scene);
    const RTCError e = rtcGetDeviceError(m.device);
    if (e != RTC_ERROR_NONE) {
        error = fmt::format("Embree: scene build failed (error {})", int(e));
        return false;
    }
    m.extent = m.lo.x <= m.hi.x ? glm::length(m.hi - m.lo) : 1.0;
    if (!(m.extent > 0.0)) m.extent = 1.0;
    m.committed = true;
    return true;
}

double ReferenceScene::rayOffset(const glm::dvec3& p) const {
    const double a = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    return 1e-5 * std::max(a, m_impl->extent);
}

bool ReferenceScene::intersect(const glm::dvec3& o, const glm::dvec3& d, double tMin, double tMax,
                               uint32_t mask, Hit& hit) const {
    const Impl& m = *m_impl;
    bool found = false;
    double best = tMax;
    for (const Sphere& s : m.spheres) {
        double t;
        if (intersectSphere(s, o, d, tMin, best, t)) {
            best = t;
            found = true;
            hit.t = t;
            hit.position = o + t * d;
            hit.geometricNormal = hit.shadingNormal = (hit.position - s.center) / s.radius;
            hit.id = s.id;
        }
    }
    for (const Plane& p : m.planes) {
        double t;
        if (intersectPlane(p, o, d, tMin, best, t)) {
            best = t;
            found = true;
            hit.t = t;
            hit.position = o + t * d;
            hit.geometricNormal = hit.shadingNormal = p.normal;
            hit.id = p.id;
        }
    }
    for (const auto& obj : m.sdfs) {
        double t;
        if ((obj->mask & mask) && intersectSdf(*obj, o, d, tMin, best, t, m.sdfCounters) && t < best) {
            best = t;
            found = true;
            hit.t = t;
            hit.position = o + t * d;
            const glm::dvec3 local = glm::dvec3(obj->toLocal * glm::dvec4(hit.position, 1.0));
            hit.geometricNormal = hit.shadingNormal = sdfNormal(*obj, local);
            hit.id = obj->id;
        }
    }
    if (m.meshes.empty()) return found;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray.org_x = float(o.x);
    rh.ray.org_y = float(o.y);
    rh.ray.org_z = float(o.z);
    rh.ray.dir_x = float(d.x);
    rh.ray.dir_y = float(d.y);
    rh.ray.dir_z = float(d.z);
    rh.ray.tnear = float(tMin);
    rh.ray.tfar = std::isfinite(best) ? float(best) : std::numeric_limits<float>::infinity();
    rh.ray.mask = mask;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(m.scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return found;
    const MeshRecord& rec = m.meshes[rh.hit.geomID];
    const uint32_t* tri = &rec.indices[size_t(rh.hit.primID) * 3];
    const glm::dvec3 &v0 = rec.positions[tri[0]], &v1 = rec.positions[tri[1]], &v2 = rec.positions[tri[2]];
    const glm::dvec3 n = glm::cross(v1 - v0, v2 - v0);
    const double nLen = glm::length(n);
    // The distance on the hit triangle's plane in double precision (Embree's is single precision).
    double t = double(rh.ray.tfar);
    const double denom = glm::dot(d, n);
    if (denom != 0.0) {
        const double tt = glm::dot(v0 - o, n) / denom;
        if (tt > tMin && tt < tMax && std::abs(tt - t) <= 1e-3 * std::max(1.0, std::abs(t))) t = tt;
    }
    if (!(t < best) && found) return true;
    hit.t = t;
    hit.position = o + t * d;
    hit.geometricNormal = nLen > 0.0 ? n / nLen : glm::dvec3(0.0, 0.0, 1.0);
    if (!rec.normals.empty()) {
        const double u = rh.hit.u, v = rh.hit.v;
        const glm::dvec3 s =
            (1.0 - u - v) * rec.normals[tri[0]] + u * rec.normals[tri[1]] + v * rec.normals[tri[2]];
        const double sLen = glm::length(s);
        hit.shadingNormal = sLen > 0.0 ? s / sLen : hit.geometricNormal;
    } else {
        hit.shadingNormal = hit.geometricNormal;
    }
    hit.id = rec.id;
    return true;
}

bool ReferenceScene::occluded(const glm::dvec3& o, const glm::dvec3& d, double tMin, double tMax,
                              uint32_t mask) const {
    const Impl& m = *m_impl;
    double t;
    for (const Sphere& s : m.spheres)
        if (intersectSphere(s, o, d, tMin, tMax, t)) return true;
    for (const Plane& p : m.planes)
        if (intersectPlane(p, o, d, tMin, tMax, t)) return true;
    for (const auto& obj : m.sdfs)
        if ((obj->mask & mask) && intersectSdf(*obj, o, d, tMin, tMax, t, m.sdfCounters)) return true;
    if (m.meshes.empty()) return false;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay ray{};
    ray.org_x = float(o.x);
    ray.org_y = float(o.y);
    ray.org_z = float(o.z);
    ray.dir_x = float(d.x);
    ray.dir_y = float(d.y);
    ray.dir_z = float(d.z);
    ray.tnear = float(tMin);
    ray.tfar = std::isfinite(tMax) ? float(tMax) : std::numeric_limits<float>::infinity();
    ray.mask = mask;
    ray.flags = 0;
    rtcOccluded1(m.scene, &ctx, &ray);
    return ray.tfar == -std::numeric_limits<float>::infinity();
}

bool buildFromWorld(const ecs::World& world, const assets::AssetManager& assets, ReferenceScene& scene,
                    std::string& error) {
    std::vector<std::pair<ecs::Entity, const ecs::MeshRenderer*>> meshes;
    std::vector<std::pair<ecs::Entity, const ecs::Light*>> lights;
    for (auto [e, mr, t] : world.view<const ecs::MeshRenderer, const ecs::Transform>()) {
        (void)t;
        if (mr.visible) meshes.push_back({e, &mr});
    }
    for (auto [e, l, t] : world.view<const ecs::Light, const ecs::Transform>()) {
        (void)t;
        if (l.castShadows) lights.push_back({e, &l});
    }
    auto byIndex = [](const auto& a, const auto& b) { return a.first.index < b.first.index; };
    std::sort(meshes.begin(), meshes.end(), byIndex);
    std::sort(lights.begin(), lights.end(), byIndex);
    for (const auto& [e, mr] : meshes) {
        const assets::MeshData* mesh = mr->mesh ? assets.mesh(mr->mesh) : nullptr;
        if (!mesh) {
            error = fmt::format("entity {}: mesh asset {:016x} is not loaded", e.index, mr->mesh);
            return false;
        }
        const glm::dmat4 model(world.get<ecs::Transform>(e)->worldMatrix);
        const uint32_t mask = kMaskCamera | (mr->castShadows ? kMaskShadow : 0u);
        if (!scene.addMesh(*mesh, model, int32_t(e.index), mask, error)) return false;
    }
    // SDF objects from their original geometry.
    std::vector<std::pair<ecs::Entity, const ecs::SdfRenderer*>> sdfs;
    for (auto [e, sr, t] : world.view<const ecs::SdfRenderer, const ecs::Transform>()) {
        (void)t;
        // occluderOnly: a rasterized mesh's baked field (--mesh-sdf occlusion); the mesh itself is exact.
        if (sr.visible && sr.sdf != 0 && sr.source != ecs::SdfSource::None && !sr.occluderOnly)
            sdfs.push_back({e, &sr});
    }
    std::sort(sdfs.begin(), sdfs.end(), byIndex);
    std::map<std::string, const assets::MeshData*> loadedMeshes;  // bakeMesh path -> mesh
    std::vector<std::unique_ptr<assets::MeshData>> ownedMeshes;   // read here (addMesh copies them)
    for (const auto& [e, sr] : sdfs) {
        const glm::dmat4 model(world.get<ecs::Transform>(e)->worldMatrix);
        const uint32_t mask = kMaskCamera | (sr->castShadows ? kMaskShadow : 0u);
        const int32_t id = int32_t(e.index);
        switch (sr->source) {
            case ecs::SdfSource::Shapes: {
                const sdf::ShapeProgram* program = assets.shapeProgram(sr->sdf);
                if (!program) {
                    error =
                        fmt::format("entity {}: shape program asset {:016x} is not loaded", e.index, sr->sdf);
                    return false;
                }
                if (!scene.addShapeProgram(*program, model, id, mask, error)) return false;
                break;
            }
            case ecs::SdfSource::MeshBake:
                if (!sr->bakeMesh.empty()) {
                    // The original mesh: the asset manager's copy of that file when it still holds
                    // it, otherwise the file read as AssetManager::loadMesh reads it.
                    auto it = loadedMeshes.find(sr->bakeMesh);
                    if (it == loadedMeshes.end()) {
                        const assets::MeshData* mesh = nullptr;
                        for (const assets::AssetInfo& info : assets.list())
                            if (info.kind == assets::AssetKind::Mesh && info.sourcePath == sr->bakeMesh &&
                                (mesh = assets.mesh(info.id)) != nullptr)
                                break;
                        if (!mesh) {
                            auto own = std::make_unique<assets::MeshData>();
                            std::string why;
                            if (!assets::loadMesh(sr->bakeMesh, *own, why) ||
                                !assets::validateMesh(*own, sr->bakeMesh, why)) {
                                error = fmt::format("entity {}: the baked mesh: {}", e.index, why);
                                return false;
                            }
                            assets::generateNormals(*own);
                            mesh = own.get();
                            ownedMeshes.push_back(std::move(own));
                        }
                        it = loadedMeshes.emplace(sr->bakeMesh, mesh).first;
                    }
                    if (!scene.addMesh(*it->second, model, id, mask, error)) return false;
                    break;
                }
                // A baked in-memory mesh has no file: the baked field is all there is.
                log::warn(
                    "reference: entity {}: the baked mesh has no file; the reference is its baked field",
                    e.index);
                [[fallthrough]];
            case ecs::SdfSource::Field: {
                const sdf::PsdfAsset* field = assets.sdfField(sr->sdf);
                if (!field) {
                    error = fmt::format("entity {}: SDF field asset {:016x} is not loaded", e.index, sr->sdf);
                    return false;
                }
                if (!scene.addSdfField(*field, model, id, mask, error)) return false;
                break;
            }
            case ecs::SdfSource::None:
                break;
        }
    }
    for (const auto& [e, l] : lights) {
        const ecs::Transform& t = *world.get<ecs::Transform>(e);
        ReferenceLight rl;
        rl.type = l->type;
        rl.position = glm::dvec3(t.worldPosition());
        rl.direction = glm::dvec3(t.worldForward());
        rl.radius = l->type == ecs::LightType::Sphere ? std::max(0.0, double(l->radius)) : 0.0;
        rl.angularRadius =
            l->type == ecs::LightType::Directional ? std::max(0.0, double(l->angularRadius)) : 0.0;
        scene.addLight(rl);
    }
    return true;
}

// ---- camera ---------------------------------------------------------------------------------------

glm::dvec3 ReferenceCamera::pixelRay(double x, double y) const {
    const double ndcX = x / double(width) * 2.0 - 1.0;
    const double ndcY = y / double(height) * 2.0 - 1.0;
    return forward + ndcX * rayRight + ndcY * rayUp;
}

namespace {
ReferenceCamera cameraFromBasis(const glm::dvec3& eye, const glm::dvec3& xAxis, const glm::dvec3& yAxis,
                                const glm::dvec3& zAxis, double fovY, uint32_t width, uint32_t height) {
    ReferenceCamera c;
    const double tanHalf = std::tan(fovY * 0.5);
    const double aspect = double(width) / double(height);
    c.eye = eye;
    c.forward = -zAxis;
    c.rayRight = xAxis * (aspect * tanHalf);  // xAxis / proj[0][0]
    c.rayUp = -yAxis * tanHalf;               // yAxis / proj[1][1], proj[1][1] < 0 (Vulkan clip space)
    c.width = width;
    c.height = height;
    return c;
}
}  // namespace

bool makeCamera(const ecs::World& world, ecs::Entity entity, uint32_t width, uint32_t height,
                ReferenceCamera& out, std::string& error) {
    const ecs::Camera* camera = world.alive(entity) ? world.get<ecs::Camera>(entity) : nullptr;
    const ecs::Transform* transform = world.alive(entity) ? world.get<ecs::Transform>(entity) : nullptr;
    if (!camera || !transform) {
        error = "reference: the camera entity has no Camera and Transform";
        return false;
    }
    if (width == 0 || height == 0) {
        error = fmt::format("reference: image size {}x{} is invalid", width, height);
        return false;
    }
    if (!std::isfinite(camera->fovY) || camera->fovY <= 0.0f || camera->fovY >= 3.14159f ||
        !std::isfinite(camera->nearPlane) || !std::isfinite(camera->farPlane) || camera->nearPlane <= 0.0f ||
        camera->farPlane <= camera->nearPlane) {
        error = fmt::format("reference: camera fovY {} must be in (0, pi) and 0 < near {} < far {}",
                            camera->fovY, camera->nearPlane, camera->farPlane);
        return false;
    }
    const glm::dmat4 cw(transform->worldMatrix);
    if (!finiteMat(cw)) {
        error = "reference: the camera's world matrix is not finite";
        return false;
    }
    glm::dvec3 z(cw[2]), x(cw[0]);
    if (glm::length(z) < 1e-12 || glm::length(x) < 1e-12) {
        error = "reference: the camera's world matrix is degenerate";
        return false;
    }
    z = glm::normalize(z);
    x = x - z * glm::dot(x, z);
    if (glm::length(x) < 1e-12) {
        error = "reference: the camera's world matrix is degenerate";
        return false;
    }
    x = glm::normalize(x);
    const glm::dvec3 y = glm::cross(z, x);
    out = cameraFromBasis(glm::dvec3(cw[3]), x, y, z, camera->fovY, width, height);
    out.nearPlane = camera->nearPlane;
    out.farPlane = camera->farPlane;
    return true;
}

ReferenceCamera lookAtCamera(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up,
                             double fovY, uint32_t width, uint32_t height) {
    const glm::dvec3 z = glm::normalize(eye - target);
    const glm::dvec3 x = glm::normalize(glm::cross(up, z));
    const glm::dvec3 y = glm::cross(z, x);
    return cameraFromBasis(eye, x, y, z, fovY, width, height);
}

// ---- estimators -------------------------------------------------------------------------------------

uint64_t pixelSeed(uint64_t seed, uint32_t x, uint32_t y, uint32_t stream) {
    uint64_t s = seed;
    uint64_t h = splitmix64(s);
    s = h ^ (uint64_t(x) << 32 | y);
    h = splitmix64(s);
    s = h ^ stream;
    return splitmix64(s);
}

uint32_t stratifiedCount(uint32_t samples) {
    uint32_t k = std::max<uint32_t>(1, uint32_t(std::ceil(std::sqrt(double(samples)))));
    while (k > 1 && (k - 1) * (k - 1) >= samples) --k;
    return k * k;
}

uint32_t samplesForError(double error) {
    if (!(error > 0.0) || !std::isfinite(error)) return 0;
    const double k = std::ceil(1.5 / error);  // 0.5 / sqrt(k * k) <= error / 3
    if (k > 4096.0) return 0;
    return uint32_t(k) * uint32_t(k);
}

Estimate ambientOcclusion(const ReferenceScene& scene, const glm::dvec3& point, const glm::dvec3& normal,
                          uint32_t samples, double maxDistance, uint64_t seed) {
    const uint32_t n = stratifiedCount(samples);
    glm::dvec3 t, b;
    basis(normal, t, b);
    const glm::dvec3 origin = point + normal * scene.rayOffset(point);
    uint32_t open = 0;
    forEachStratum(n, seed, [&](double u1, double u2) {
        // Cosine-weighted (Malley): a uniform point on the unit disk lifted to the hemisphere.
        const double r = std::sqrt(u1), phi = 2.0 * kPi * u2;
        const glm::dvec3 dir =
            t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + normal * std::sqrt(std::max(0.0, 1.0 - u1));
        if (!scene.occluded(origin, dir, 0.0, maxDistance, kMaskCamera)) ++open;
    });
    return bernoulli(open, n);
}

Estimate lightVisibility(const ReferenceScene& scene, const ReferenceLight& light, const glm::dvec3& point,
                         const glm::dvec3& normal, uint32_t samples, uint64_t seed) {
    const glm::dvec3 origin = point + normal * scene.rayOffset(point);
    glm::dvec3 axis;
    double oneMinusCos = 0.0;  // 1 - cos(cone half-angle)
    double lightDistance = kInf;
    const bool directional = light.type == ecs::LightType::Directional;
    if (directional) {
        axis = -glm::normalize(light.direction);
        const double a = std::min(light.angularRadius, kPi * 0.5);
        oneMinusCos = 2.0 * std::sin(a * 0.5) * std::sin(a * 0.5);
    } else {
        const glm::dvec3 toLight = light.position - point;
        lightDistance = glm::length(toLight);
        const double radius = light.type == ecs::LightType::Sphere ? light.radius : 0.0;
        if (radius > 0.0 && lightDistance <= radius) return {1.0, 0.0, 1};  // inside the light
        axis = toLight / lightDistance;
        if (radius > 0.0) {
            const double s = radius / lightDistance;  // sin of the half-angle
            oneMinusCos = s * s / (1.0 + std::sqrt(1.0 - s * s));
        }
    }
    // A hard light: one ray.
    if (oneMinusCos <= 0.0) {
        if (glm::dot(axis, normal) <= 0.0) return {0.0, 0.0, 1};
        const double tMax = directional ? kInf : glm::length(light.position - origin);
        return {scene.occluded(origin, axis, 0.0, tMax, kMaskShadow) ? 0.0 : 1.0, 0.0, 1};
    }
    const uint32_t n = stratifiedCount(samples);
    glm::dvec3 t, b;
    basis(axis, t, b);
    uint32_t open = 0;
    forEachStratum(n, seed, [&](double u1, double u2) {
        // Uniform in solid angle over the cone: cos(theta) uniform in [cos(alpha), 1].
        const double h = u1 * oneMinusCos;  // 1 - cos(theta)
        const double cosT = 1.0 - h, sinT = std::sqrt(std::max(0.0, h * (2.0 - h)));
        const double phi = 2.0 * kPi * u2;
        const glm::dvec3 dir = t * (sinT * std::cos(phi)) + b * (sinT * std::sin(phi)) + axis * cosT;
        if (glm::dot(dir, normal) <= 0.0) return;  // below the surface: occluded by it
        double tMax = kInf;
        if (!directional) {
            // Up to the near surface of the sphere light.
            const glm::dvec3 toC = light.position - origin;
            const double along = glm::dot(dir, toC);
            const double perp2 = std::max(0.0, glm::dot(toC, toC) - along * along);
            tMax = along - std::sqrt(std::max(0.0, light.radius * light.radius - perp2));
            if (!(tMax > 0.0)) tMax = along;
        }
        if (!scene.occluded(origin, dir, 0.0, tMax, kMaskShadow)) ++open;
    });
    return bernoulli(open, n);
}

// ---- AOVs -------------------------------------------------------------------------------------------

std::string AovRequest::name() const {
    switch (kind) {
        case AovKind::Depth:
            return "depth";
        case AovKind::Normal:
            return "normal";
        case AovKind::Ids:
            return "ids";
        case AovKind::Ao:
            return "ao";
        case AovKind::Shadow:
            return light == 0 ? "shadow" : fmt::format("shadow{}", light);
    }
    return "?";
}

bool parseAovList(const std::string& list, std::vector<AovRequest>& out, std::string& error) {
    out.clear();
    std::stringstream ss(list);
    std::string item;
    while (std::getline(ss, item, ',')) {
        AovRequest r;
        if (item == "depth")
            r.kind = AovKind::Depth;
        else if (item == "normal")
            r.kind = AovKind::Normal;
        else if (item == "ids")
            r.kind = AovKind::Ids;
        else if (item == "ao")
            r.kind = AovKind::Ao;
        else if (item.rfind("shadow", 0) == 0) {
            r.kind = AovKind::Shadow;
            const std::string digits = item.substr(6);
            if (!digits.empty()) {
                if (digits.size() > 5 ||
                    !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
                    error = fmt::format("unknown AOV '{}' (depth, normal, ids, ao, shadow, shadowN)", item);
                    return false;
                }
                r.light = uint32_t(std::stoul(digits));
            }
        } else {
            error = fmt::format("unknown AOV '{}' (depth, normal, ids, ao, shadow, shadowN)", item);
            return false;
        }
        for (const AovRequest& o : out)
            if (o.kind == r.kind && o.light == r.light) {
                error = fmt::format("AOV '{}' is listed twice", item);
                return false;
            }
        out.push_back(r);
    }
    if (out.empty()) {
        error = "no AOV requested (depth, normal, ids, ao, shadow, shadowN)";
        return false;
    }
    return true;
}

bool render(const ReferenceScene& scene, const ReferenceCamera& camera, const RenderDesc& desc,
            std::vector<AovImage>& out, std::string& error) {
    if (camera.width == 0 || camera.height == 0) {
        error = "reference: the camera has no image size";
        return false;
    }
    if (desc.samples == 0) {
        error = "reference: the sample count must be at least 1";
        return false;
    }
    if (!(desc.aoMaxDistance > 0.0)) {
        error = fmt::format("reference: the AO distance {} must be > 0 (inf: unbounded)", desc.aoMaxDistance);
        return false;
    }
    for (const AovRequest& r : desc.aovs)
        if (r.kind == AovKind::Shadow && r.light >= scene.lights().size()) {
            error =
                fmt::format("reference: AOV '{}' needs shadowed light {}, the scene has {} shadowed light(s)",
                            r.name(), r.light, scene.lights().size());
            return false;
        }
    const uint32_t w = camera.width, h = camera.height;
    const uint32_t samples = stratifiedCount(desc.samples);
    out.clear();
    for (const AovRequest& r : desc.aovs) {
        AovImage img;
        img.name = r.name();
        img.width = w;
        img.height = h;
        img.channels = r.kind == AovKind::Normal ? 3 : 1;
        img.data.assign(size_t(w) * h * img.channels, r.kind == AovKind::Ids ? -1.0f : 0.0f);
        img.samples = r.kind == AovKind::Ao ? samples : 0;
        if (r.kind == AovKind::Shadow) {
            const ReferenceLight& l = scene.lights()[r.light];
            const bool area = l.type == ecs::LightType::Directional ? l.angularRadius > 0.0
                              : l.type == ecs::LightType::Sphere    ? l.radius > 0.0
                                                                    : false;
            img.samples = area ? samples : 1;  // a hard light is one ray
        }
        out.push_back(std::move(img));
    }
    constexpr uint32_t kTile = 16;
    const uint32_t tilesX = (w + kTile - 1) / kTile, tilesY = (h + kTile - 1) / kTile;
    const uint32_t tileCount = tilesX * tilesY;
    // Standard-error statistics per tile (each tile is one thread's, in pixel order), added up in
    // tile order afterwards: the results do not depend on the thread count.
    struct TileStats {
        size_t hits = 0;
        std::vector<double> sum, max;
    };
    std::vector<TileStats> tileStats(
        tileCount, TileStats{0, std::vector<double>(out.size(), 0.0), std::vector<double>(out.size(), 0.0)});
    std::atomic<uint32_t> nextTile{0}, doneTiles{0};
    auto worker = [&]() {
        for (uint32_t tile = nextTile++; tile < tileCount; tile = nextTile++) {
            const uint32_t x0 = (tile % tilesX) * kTile, y0 = (tile / tilesX) * kTile;
            TileStats& ts = tileStats[tile];
            for (uint32_t y = y0; y < std::min(h, y0 + kTile); ++y)
                for (uint32_t x = x0; x < std::min(w, x0 + kTile); ++x) {
                    const glm::dvec3 ray = camera.pixelRay(x + 0.5, y + 0.5);
                    Hit hit;
                    if (!scene.intersect(camera.eye, ray, camera.nearPlane, camera.farPlane, kMaskCamera,
                                         hit) ||
                        !(hit.t >= camera.nearPlane))
                        continue;
                    ++ts.hits;
                    // Secondary rays leave the side of the surface the camera sees.
                    glm::dvec3 ng = hit.geometricNormal;
                    if (glm::dot(ng, ray) > 0.0) ng = -ng;
                    const size_t pixel = size_t(y) * w + x;
                    for (size_t a = 0; a < desc.aovs.size(); ++a) {
                        AovImage& img = out[a];
                        const AovRequest& r = desc.aovs[a];
                        Estimate e;
                        switch (r.kind) {
                            case AovKind::Depth:
                                img.data[pixel] = float(hit.t);
                                break;
                            case AovKind::Normal:
                                img.data[pixel * 3 + 0] = float(hit.shadingNormal.x);
                                img.data[pixel * 3 + 1] = float(hit.shadingNormal.y);
                                img.data[pixel * 3 + 2] = float(hit.shadingNormal.z);
                                break;
                            case AovKind::Ids:
                                img.data[pixel] = float(hit.id);
                                break;
                            case AovKind::Ao:
                                e = ambientOcclusion(scene, hit.position, ng, samples, desc.aoMaxDistance,
                                                     pixelSeed(desc.seed, x, y, 1));
                                img.data[pixel] = float(e.value);
                                break;
                            case AovKind::Shadow:
                                e = lightVisibility(scene, scene.lights()[r.light], hit.position, ng, samples,
                                                    pixelSeed(desc.seed, x, y, 2 + r.light));
                                img.data[pixel] = float(e.value);
                                break;
                        }
                        ts.sum[a] += e.stdError;
                        ts.max[a] = std::max(ts.max[a], e.stdError);
                    }
                }
            const uint32_t done = ++doneTiles;
            if (desc.progress) desc.progress(double(done) / double(tileCount));
        }
    };
    uint32_t threads = desc.threads ? desc.threads : std::max(1u, std::thread::hardware_concurrency());
    threads = std::min(threads, tileCount);
    const uint64_t unconvergedBefore = scene.sdfStats().unconverged;
    std::vector<std::thread> pool;
    for (uint32_t i = 1; i < threads; ++i) pool.emplace_back(worker);
    worker();
    for (std::thread& t : pool) t.join();
    if (const uint64_t unconverged = scene.sdfStats().unconverged - unconvergedBefore; unconverged > 0)
        log::warn(
            "reference: {} ray(s) did not converge on an SDF object within {} sphere-tracing iterations "
            "(counted as misses)",
            unconverged, kSdfMaxIterations);
    size_t hits = 0;
    for (const TileStats& ts : tileStats) hits += ts.hits;
    for (size_t a = 0; a < out.size(); ++a) {
        double sum = 0.0, maxSe = 0.0;
        for (const TileStats& ts : tileStats) {
            sum += ts.sum[a];
            maxSe = std::max(maxSe, ts.max[a]);
        }
        out[a].meanStdError = hits ? sum / double(hits) : 0.0;
        out[a].maxStdError = maxSe;
    }
    return true;
}

}  // namespace penumbra::reference
