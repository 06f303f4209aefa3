// Generalized winding number (exact, hierarchical) and ray parity: analytic values, fast vs exact on
// synthetic and real (open, non-manifold) meshes, parity ties at edges and vertices, threads,
// degenerate input.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <glm/geometric.hpp>

#include "engine/assets/mesh.h"
#include "engine/sdf/winding.h"

namespace penumbra::sdf {
namespace {

constexpr double kPi = std::numbers::pi;

struct Mesh {
    std::vector<glm::dvec3> positions;
    std::vector<glm::uvec3> triangles;
};

// Cube [lo, hi]^3, 12 outward (counter-clockwise) triangles; each face's diagonal passes through
// the face centre.
Mesh cube(double lo = -1, double hi = 1) {
    Mesh m;
    for (int k = 0; k < 8; ++k) m.positions.push_back({k & 1 ? hi : lo, k & 2 ? hi : lo, k & 4 ? hi : lo});
    const uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                  {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : faces) {
        m.triangles.push_back({f[0], f[1], f[2]});
        m.triangles.push_back({f[0], f[2], f[3]});
    }
    return m;
}

// Octahedron with vertices (+-1, 0, 0), (0, +-1, 0), (0, 0, +-1), outward.
Mesh octahedron() {
    Mesh m;
    m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (uint32_t x : {0u, 1u})
        for (uint32_t y : {2u, 3u})
            for (uint32_t z : {4u, 5u}) {
                // Outward when (x, y, z) is right-handed: flip for an odd number of negative axes.
                const bool flip = ((x == 1) + (y == 3) + (z == 5)) % 2 == 1;
                m.triangles.push_back(flip ? glm::uvec3(x, z, y) : glm::uvec3(x, y, z));
            }
    return m;
}

// Unit sphere as latitude/longitude grid with poles (0, 0, +-1). With `rings` even the equator is a
// ring. `openBelowEquator` keeps only the upper hemisphere (open at z = 0).
Mesh uvSphere(uint32_t slices, uint32_t rings, bool upperHemisphereOnly = false, double radius = 1,
              glm::dvec3 centre = glm::dvec3(0)) {
    Mesh m;
    const uint32_t lastRing = upperHemisphereOnly ? rings / 2 : rings;  // ring index of the last row
    m.positions.push_back(centre + glm::dvec3(0, 0, radius));           // north pole
    for (uint32_t r = 1; r <= lastRing && r < rings; ++r) {
        const double theta = kPi * r / rings;
        for (uint32_t s = 0; s < slices; ++s) {
            const double phi = 2 * kPi * s / slices;
            m.positions.push_back(centre + radius * glm::dvec3(std::sin(theta) * std::cos(phi),
                                                               std::sin(theta) * std::sin(phi),
                                                               std::cos(theta)));
        }
    }
    auto ring = [&](uint32_t r, uint32_t s) { return 1 + (r - 1) * slices + s % slices; };
    for (uint32_t s = 0; s < slices; ++s) m.triangles.push_back({0, ring(1, s), ring(1, s + 1)});
    for (uint32_t r = 1; r + 1 <= lastRing && r + 1 < rings; ++r)
        for (uint32_t s = 0; s < slices; ++s) {
            m.triangles.push_back({ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
            m.triangles.push_back({ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
        }
    if (!upperHemisphereOnly) {
        m.positions.push_back(centre + glm::dvec3(0, 0, -radius));  // south pole
        const uint32_t south = uint32_t(m.positions.size() - 1);
        for (uint32_t s = 0; s < slices; ++s)
            m.triangles.push_back({south, ring(rings - 1, s + 1), ring(rings - 1, s)});
    }
    return m;
}

double frac(std::mt19937_64& rng) { return std::uniform_real_distribution<double>(0, 1)(rng); }

glm::dvec3 randomIn(std::mt19937_64& rng, glm::dvec3 lo, glm::dvec3 hi) {
    return lo + (hi - lo) * glm::dvec3(frac(rng), frac(rng), frac(rng));
}

// Points near the surface (random triangle point + normal offset up to `offset`), plus random
// points in the box [lo, hi].
std::vector<glm::dvec3> mixedPoints(const Mesh& m, size_t count, double offset, glm::dvec3 lo, glm::dvec3 hi,
                                    uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::vector<glm::dvec3> pts;
    for (size_t i = 0; i < count; ++i) {
        if (i % 2 == 0) {
            pts.push_back(randomIn(rng, lo, hi));
            continue;
        }
        const glm::uvec3 t = m.triangles[rng() % m.triangles.size()];
        double u = frac(rng), v = frac(rng);
        if (u + v > 1) u = 1 - u, v = 1 - v;
        const glm::dvec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
        glm::dvec3 n = glm::cross(b - a, c - a);
        const double len = glm::length(n);
        if (len > 0) n /= len;
        pts.push_back(a + u * (b - a) + v * (c - a) + n * (2 * frac(rng) - 1) * offset);
    }
    return pts;
}

struct Agreement {
    size_t points = 0, considered = 0, agree = 0;
    double maxError = 0, meanError = 0;
    double rate() const { return considered ? double(agree) / double(considered) : 1.0; }
};

// exact() at every point, on two threads (it is O(n) per point).
std::vector<double> exactValues(const WindingNumber& w, const std::vector<glm::dvec3>& pts) {
    std::vector<double> values(pts.size());
    auto run = [&](size_t first) {
        for (size_t i = first; i < pts.size(); i += 2) values[i] = w.exact(pts[i]);
    };
    std::thread other(run, 1);
    run(0);
    other.join();
    return values;
}

// fast() against exact(): |error| over all points; sign (w > 0.5) where |w_exact - 0.5| > 0.2.
Agreement compareFast(const WindingNumber& w, const std::vector<glm::dvec3>& pts,
                      const std::vector<double>& exact) {
    Agreement a;
    for (size_t i = 0; i < pts.size(); ++i) {
        const double we = exact[i], wf = w.fast(pts[i]);
        const double err = std::abs(we - wf);
        a.maxError = std::max(a.maxError, err);
        a.meanError += err;
        ++a.points;
        if (std::abs(we - 0.5) > 0.2) {
            ++a.considered;
            a.agree += (we > 0.5) == (wf > 0.5);
        }
    }
    if (a.points) a.meanError /= double(a.points);
    return a;
}

Agreement compareFast(const WindingNumber& w, const std::vector<glm::dvec3>& pts) {
    return compareFast(w, pts, exactValues(w, pts));
}

// Solid angle of the rectangle [x0, x1] x [y0, y1] in the plane z = zPlane, seen from q (unsigned).
double rectangleSolidAngle(double x0, double x1, double y0, double y1, double zPlane, glm::dvec3 q) {
    const double d = std::abs(zPlane - q.z);
    auto f = [&](double x, double y) {
        const double X = x - q.x, Y = y - q.y;
        return std::atan(X * Y / (d * std::sqrt(X * X + Y * Y + d * d)));
    };
    return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0);
}

TEST(Winding, ExactIsOneInsideZeroOutsideClosedCube) {
    const Mesh m = cube();
    const WindingNumber w(m.positions, m.triangles);
    std::mt19937_64 rng(1);
    for (int i = 0; i < 200; ++i) {
        const glm::dvec3 in = randomIn(rng, glm::dvec3(-0.99), glm::dvec3(0.99));
        EXPECT_NEAR(w.exact(in), 1.0, 1e-9) << in.x << " " << in.y << " " << in.z;
        glm::dvec3 out = randomIn(rng, glm::dvec3(-3), glm::dvec3(3));
        if (std::max({std::abs(out.x), std::abs(out.y), std::abs(out.z)}) < 1.01) out.x += 2.5;
        EXPECT_NEAR(w.exact(out), 0.0, 1e-9) << out.x << " " << out.y << " " << out.z;
    }
}

TEST(Winding, ExactIsOneInsideZeroOutsideClosedSphere) {
    const Mesh m = uvSphere(48, 24);
    const WindingNumber w(m.positions, m.triangles);
    std::mt19937_64 rng(2);
    for (int i = 0; i < 200; ++i) {
        const glm::dvec3 dir =
            glm::normalize(randomIn(rng, glm::dvec3(-1), glm::dvec3(1)) + glm::dvec3(1e-3));
        // The mesh is inscribed in the unit sphere: inside below 0.99, outside beyond 1.
        const glm::dvec3 in = dir * (0.98 * frac(rng));
        const glm::dvec3 out = dir * (1.001 + 3 * frac(rng));
        EXPECT_NEAR(w.exact(in), 1.0, 1e-9);
        EXPECT_NEAR(w.exact(out), 0.0, 1e-9);
    }
}

TEST(Winding, OpenBoxMatchesAnalyticSolidAngle) {
    // Cube without its top face (z = 1): w = [inside cube] - (top face's signed solid angle) / 4 pi.
    Mesh m = cube();
    m.triangles.erase(m.triangles.begin() + 2, m.triangles.begin() + 4);  // face {4, 5, 7, 6}: z = 1
    const WindingNumber w(m.positions, m.triangles);
    std::mt19937_64 rng(3);
    for (int i = 0; i < 300; ++i) {
        const glm::dvec3 q = randomIn(rng, glm::dvec3(-2), glm::dvec3(2));
        if (std::abs(q.z - 1) < 1e-3) continue;
        const bool inside = std::max({std::abs(q.x), std::abs(q.y), std::abs(q.z)}) < 1;
        const double topSign = q.z < 1 ? 1.0 : -1.0;  // outward normal +z: positive seen from below
        const double expected =
            (inside ? 1.0 : 0.0) - topSign * rectangleSolidAngle(-1, 1, -1, 1, 1, q) / (4 * kPi);
        EXPECT_NEAR(w.exact(q), expected, 1e-9) << q.x << " " << q.y << " " << q.z;
        EXPECT_NEAR(w.fast(q), expected, 0.02) << q.x << " " << q.y << " " << q.z;
    }
    // The centre of the missing face: exactly half.
    EXPECT_NEAR(w.exact(glm::dvec3(0, 0, 1)), 0.5, 1e-12);
}

TEST(Winding, OpenHemisphereMatchesAnalyticOnAxis) {
    // Upper unit hemisphere, open at z = 0. On the axis, w = [inside the closed half-ball] minus the
    // signed solid angle of the missing unit disk (normal -z): sign(h) (1 - |h| / sqrt(1 + h^2)) / 2.
    // The mesh is a polygonal approximation (256 slices): tolerance 1e-3.
    const Mesh m = uvSphere(256, 128, true);
    const WindingNumber w(m.positions, m.triangles);
    for (double h : {-3.0, -1.0, -0.5, -0.1, 0.05, 0.3, 0.6, 0.9, 1.2, 2.0, 5.0}) {
        const double disk = (h > 0 ? 1.0 : -1.0) * (1 - std::abs(h) / std::sqrt(1 + h * h)) / 2;
        const double inside = (h > 0 && h < 1) ? 1.0 : 0.0;
        const double expected = inside - disk;
        EXPECT_NEAR(w.exact(glm::dvec3(0, 0, h)), expected, 1e-3) << "h = " << h;
        EXPECT_NEAR(w.fast(glm::dvec3(0, 0, h)), expected, 0.05) << "h = " << h;  // measured <= 0.028
    }
    EXPECT_NEAR(w.exact(glm::dvec3(0, 0, 0)), 0.5, 1e-3);  // centre of the missing disk
}

TEST(Winding, FastMatchesExactOnClosedSphere) {
    const Mesh m = uvSphere(96, 48);
    const WindingNumber w(m.positions, m.triangles);
    // Half the points within 0.05 of the surface, half in [-2, 2]^3.
    const Agreement a = compareFast(w, mixedPoints(m, 4000, 0.05, glm::dvec3(-2), glm::dvec3(2), 4));
    std::printf("[winding] closed sphere (%zu triangles): max |fast - exact| %.4f, mean %.5f, sign %zu/%zu\n",
                m.triangles.size(), a.maxError, a.meanError, a.agree, a.considered);
    EXPECT_LT(a.maxError, 0.1);  // measured 0.062 (beta 2)
    EXPECT_LT(a.meanError, 0.02);
    EXPECT_GE(a.rate(), 0.999);
}

TEST(Winding, FastMatchesExactOnOpenAndNonManifoldMesh) {
    // A sphere with holes (every 7th triangle removed), a flipped patch, and non-manifold fins.
    Mesh m = uvSphere(96, 48, false, 1.0, glm::dvec3(0.3, -0.2, 0.1));
    Mesh open;
    open.positions = m.positions;
    for (size_t i = 0; i < m.triangles.size(); ++i) {
        if (i % 7 == 3) continue;
        glm::uvec3 t = m.triangles[i];
        if (i % 97 == 5) std::swap(t.y, t.z);  // a few inconsistently oriented triangles
        open.triangles.push_back(t);
    }
    for (size_t i = 0; i < m.triangles.size(); i += 53) {  // fins: third triangle on an edge
        const glm::uvec3 t = m.triangles[i];
        open.positions.push_back(glm::dvec3(0.3, -0.2, 0.1) +
                                 1.3 * (m.positions[t.x] - glm::dvec3(0.3, -0.2, 0.1)));
        open.triangles.push_back({t.x, t.y, uint32_t(open.positions.size() - 1)});
    }
    const WindingNumber w(open.positions, open.triangles);
    const Agreement a = compareFast(w, mixedPoints(open, 4000, 0.05, glm::dvec3(-2), glm::dvec3(2), 5));
    std::printf("[winding] open sphere (%zu triangles): max |fast - exact| %.4f, mean %.5f, sign %zu/%zu\n",
                open.triangles.size(), a.maxError, a.meanError, a.agree, a.considered);
    EXPECT_LT(a.maxError, 0.1);  // measured 0.041 (beta 2)
    EXPECT_LT(a.meanError, 0.02);
    EXPECT_GE(a.rate(), 0.999);
    EXPECT_GT(a.considered, 2000u);
}

TEST(Winding, BetaTradesAccuracy) {
    const Mesh m = uvSphere(64, 32);
    const std::vector<glm::dvec3> pts = mixedPoints(m, 1000, 0.1, glm::dvec3(-2), glm::dvec3(2), 6);
    double previous = 1;
    for (double beta : {1.5, 2.0, 4.0, 1e9}) {
        const WindingNumber w(m.positions, m.triangles, beta);
        const Agreement a = compareFast(w, pts);
        EXPECT_LE(a.meanError, previous * 1.05) << "beta " << beta;
        previous = a.meanError;
    }
    EXPECT_LT(previous, 1e-5);  // beta = 1e9: every triangle exact (float arithmetic)
}

TEST(Winding, ParityMatchesExactOnClosedMeshes) {
    for (const Mesh& m : {cube(-0.7, 1.3), uvSphere(40, 20), octahedron()}) {
        const WindingNumber w(m.positions, m.triangles);
        const std::vector<glm::dvec3> pts = mixedPoints(m, 2000, 0.02, glm::dvec3(-2), glm::dvec3(2), 7);
        size_t agree = 0;
        for (const glm::dvec3& p : pts) agree += w.parityInside(p) == (w.exact(p) > 0.5);
        EXPECT_EQ(agree, pts.size());
    }
}

TEST(Winding, ParityCountsRaysThroughEdgesAndVerticesOnce) {
    // Axis-aligned and diagonal rays from points on symmetry axes pass exactly through face
    // diagonals (edges) and corners (vertices). All three votes use the same direction, so each
    // single ray must be right.
    struct Case {
        Mesh mesh;
        glm::dvec3 point, dir;
        bool inside;
        const char* what;
    };
    const glm::dvec3 diag = glm::normalize(glm::dvec3(1, 1, 1));
    const std::vector<Case> cases = {
        {cube(), {0, 0, 0}, {1, 0, 0}, true, "cube centre, +x through a face diagonal"},
        {cube(), {0, 0, 0}, {0, 0, -1}, true, "cube centre, -z through a face diagonal"},
        {cube(), {0.25, 0.25, 0}, {0, 0, 1}, true, "cube, +z through a face diagonal off-centre"},
        {cube(), {0, 0, 0}, diag, true, "cube centre, diagonal through a corner"},
        {cube(), {-0.5, -0.5, -0.5}, diag, true, "cube, diagonal through a corner"},
        {cube(), {3, 0, 0}, {-1, 0, 0}, false, "outside cube, -x through two face diagonals"},
        {cube(), {2, 2, 2}, -diag, false, "outside cube, diagonal through two corners"},
        {cube(), {3, 1, 0}, {-1, 0, 0}, false, "outside cube, ray along a face, through two edges"},
        {cube(), {3, 1, 1}, {-1, 0, 0}, false, "outside cube, ray along an edge"},
        {octahedron(), {0, 0, 0}, {1, 0, 0}, true, "octahedron centre, +x through a vertex"},
        {octahedron(), {0, 0, 0.5}, {0, 0, 1}, true, "octahedron, +z through the apex"},
        {octahedron(), {0, 0, -3}, {0, 0, 1}, false, "outside octahedron, through both apices"},
        {octahedron(), {0.25, 0.25, 0}, {0, 0, 1}, true, "octahedron, +z through an edge"},
        {uvSphere(32, 16), {0, 0, 0.3}, {0, 0, 1}, true, "sphere, +z through the pole (32 triangles)"},
        {uvSphere(32, 16), {0, 0, -3}, {0, 0, 1}, false, "outside sphere, through both poles"},
        {uvSphere(32, 16), {0, 0, 0}, {1, 0, 0}, true, "sphere centre, +x through an equator vertex"},
    };
    for (const Case& c : cases) {
        WindingNumber w(c.mesh.positions, c.mesh.triangles);
        w.setParityDirections(c.dir, c.dir, c.dir);
        EXPECT_EQ(w.parityInside(c.point), c.inside) << c.what;
        EXPECT_EQ(w.exact(c.point) > 0.5, c.inside) << c.what;
    }
}

TEST(Winding, ParityIsRobustOnSymmetryAxes) {
    // Default directions; points on the axes and diagonals of symmetric meshes.
    for (const Mesh& m : {cube(), octahedron(), uvSphere(16, 8)}) {
        const WindingNumber w(m.positions, m.triangles);
        for (double t : {-2.5, -0.9, -0.5, -0.25, 0.0, 0.25, 0.5, 0.9, 2.5}) {
            for (glm::dvec3 axis :
                 {glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1),
                  glm::normalize(glm::dvec3(1, 1, 1)), glm::normalize(glm::dvec3(1, -1, 0))}) {
                const glm::dvec3 p = axis * t;
                const double we = w.exact(p);
                if (std::abs(we - 0.5) < 0.4) continue;  // on the surface
                EXPECT_EQ(w.parityInside(p), we > 0.5) << p.x << " " << p.y << " " << p.z;
            }
        }
    }
}

TEST(Winding, ParallelQueriesGiveIdenticalResults) {
    const Mesh m = uvSphere(64, 32);
    const WindingNumber w(m.positions, m.triangles);
    const std::vector<glm::dvec3> pts = mixedPoints(m, 3000, 0.05, glm::dvec3(-2), glm::dvec3(2), 8);
    std::vector<double> serial(pts.size());
    std::vector<char> serialParity(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) {
        serial[i] = w.fast(pts[i]);
        serialParity[i] = w.parityInside(pts[i]);
    }
    constexpr int kThreads = 4;
    std::vector<std::vector<double>> values(kThreads, std::vector<double>(pts.size()));
    std::vector<std::vector<char>> parity(kThreads, std::vector<char>(pts.size()));
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t)
        threads.emplace_back([&, t] {
            for (size_t k = 0; k < pts.size(); ++k) {
                const size_t i = (k * 7 + size_t(t) * 131) % pts.size();  // different orders
                values[t][i] = w.fast(pts[i]);
                parity[t][i] = w.parityInside(pts[i]);
            }
        });
    for (auto& th : threads) th.join();
    for (int t = 0; t < kThreads; ++t) {
        EXPECT_EQ(values[t], serial);
        EXPECT_EQ(parity[t], serialParity);
    }
}

TEST(Winding, DegenerateTrianglesAddNothing) {
    const Mesh base = cube();
    Mesh m = base;
    // Repeated indices, collinear vertices, a zero-size triangle, an out-of-range index.
    m.positions.push_back({0.5, 0.5, 0.5});
    m.positions.push_back({0.25, 0.25, 0.25});
    const uint32_t a = uint32_t(m.positions.size() - 2), b = a + 1;
    m.triangles.push_back({0, 0, 0});
    m.triangles.push_back({0, 7, 7});
    m.triangles.push_back({0, b, a});  // collinear with vertex 0 = (-1, -1, -1)
    m.triangles.push_back({a, a, b});
    m.triangles.push_back({0, 1, 9999});
    const WindingNumber wb(base.positions, base.triangles);
    const WindingNumber w(m.positions, m.triangles);
    const std::vector<glm::dvec3> pts = mixedPoints(base, 500, 0.1, glm::dvec3(-2), glm::dvec3(2), 9);
    for (const glm::dvec3& p : pts) {
        EXPECT_EQ(w.exact(p), wb.exact(p));
        EXPECT_EQ(w.fast(p), wb.fast(p));
        EXPECT_EQ(w.parityInside(p), wb.parityInside(p));
    }
    // Queries on the degenerate triangles' vertices and line: finite, inside.
    for (const glm::dvec3& p :
         {glm::dvec3(0.5, 0.5, 0.5), glm::dvec3(0.25, 0.25, 0.25), glm::dvec3(0.4, 0.4, 0.4)}) {
        EXPECT_TRUE(std::isfinite(w.exact(p)));
        EXPECT_TRUE(std::isfinite(w.fast(p)));
        EXPECT_NEAR(w.exact(p), 1.0, 1e-9);
        EXPECT_NEAR(w.fast(p), 1.0, 1e-3);
        EXPECT_TRUE(w.parityInside(p));
    }
    // Only degenerate triangles: zero everywhere.
    Mesh flat;
    flat.positions = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
    flat.triangles = {{0, 1, 2}, {0, 0, 1}};
    const WindingNumber wf(flat.positions, flat.triangles);
    for (const glm::dvec3& p : {glm::dvec3(0, 0, 0), glm::dvec3(1.5, 1.5, 1.5), glm::dvec3(3, 0, 1)}) {
        EXPECT_EQ(wf.exact(p), 0.0);
        EXPECT_EQ(wf.fast(p), 0.0);
        EXPECT_FALSE(wf.parityInside(p));
    }
}

TEST(Winding, EmptySingleTriangleAndNonFiniteQueries) {
    const std::vector<glm::dvec3> noPositions;
    const std::vector<glm::uvec3> noTriangles;
    const WindingNumber empty(noPositions, noTriangles);
    EXPECT_EQ(empty.exact(glm::dvec3(0)), 0.0);
    EXPECT_EQ(empty.fast(glm::dvec3(0)), 0.0);
    EXPECT_FALSE(empty.parityInside(glm::dvec3(0)));

    // One triangle: w = signed solid angle / 4 pi. Seen from its normal axis far away, small.
    const std::vector<glm::dvec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const std::vector<glm::uvec3> t = {{0, 1, 2}};
    const WindingNumber one(p, t);
    const glm::dvec3 below(0.25, 0.25, -0.5), above(0.25, 0.25, 0.5);
    EXPECT_GT(one.exact(below), 0.0);
    EXPECT_NEAR(one.exact(below), -one.exact(above), 1e-12);
    EXPECT_NEAR(one.fast(below), one.exact(below), 1e-6);  // a single leaf: exact
    EXPECT_NEAR(one.fast(glm::dvec3(30, -20, 40)), one.exact(glm::dvec3(30, -20, 40)), 1e-6);
    EXPECT_FALSE(one.parityInside(below));  // one crossing for some rays, none for others: majority

    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_TRUE(std::isnan(one.fast(glm::dvec3(nan, 0, 0))));
    EXPECT_FALSE(one.parityInside(glm::dvec3(0, nan, 0)));
    EXPECT_FALSE(one.parityInside(glm::dvec3(0, 0, std::numeric_limits<double>::infinity())));
}

TEST(Winding, FarFromOriginAndTinyOrHugeUnits) {
    // The same sphere at offset 1e5, scaled by 1e-6 and by 1e6: identical signs.
    const Mesh ref = uvSphere(48, 24);
    const std::vector<glm::dvec3> pts = mixedPoints(ref, 600, 0.02, glm::dvec3(-2), glm::dvec3(2), 10);
    const WindingNumber wr(ref.positions, ref.triangles);
    for (auto [offset, scale] : {std::pair{1e5, 1.0}, std::pair{0.0, 1e-6}, std::pair{-3e3, 1e6}}) {
        Mesh m = ref;
        for (auto& v : m.positions) v = v * scale + glm::dvec3(offset, -offset, offset);
        const WindingNumber w(m.positions, m.triangles);
        for (const glm::dvec3& p0 : pts) {
            const glm::dvec3 p = p0 * scale + glm::dvec3(offset, -offset, offset);
            const double we = wr.exact(p0);
            EXPECT_NEAR(w.exact(p), we, 1e-6);
            EXPECT_NEAR(w.fast(p), wr.fast(p0), 1e-4);
            if (std::abs(we - 0.5) > 0.2) {
                EXPECT_EQ(w.parityInside(p), we > 0.5);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Real meshes from data/meshes (tools/fetch_meshes.sh).

Mesh loadDataMesh(const std::string& name) {
    const std::string path = std::string(PENUMBRA_SOURCE_DIR) + "/data/meshes/" + name;
    Mesh m;
    if (!std::filesystem::exists(path)) {
        ADD_FAILURE() << "missing test mesh " << path << ": run tools/fetch_meshes.sh first";
        return m;
    }
    assets::MeshData data;
    std::string error;
    if (!assets::loadMesh(path, data, error)) {
        ADD_FAILURE() << "cannot load " << path << ": " << error;
        return m;
    }
    for (const glm::vec3& v : data.positions) m.positions.push_back(glm::dvec3(v));
    for (size_t i = 0; i + 2 < data.indices.size(); i += 3)
        m.triangles.push_back({data.indices[i], data.indices[i + 1], data.indices[i + 2]});
    return m;
}

// Random points in the bounding box padded by 2 voxels of a 128 grid: fast vs exact, parity vs
// exact; build time and fast()/parity cost printed (not asserted).
void checkRealMesh(const std::string& name, size_t exactPoints) {
    const Mesh m = loadDataMesh(name);
    if (m.triangles.empty()) return;
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const glm::dvec3& v : m.positions) lo = glm::min(lo, v), hi = glm::max(hi, v);
    const double pad = 2 * std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}) / 124;
    lo -= pad;
    hi += pad;

    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    const WindingNumber w(m.positions, m.triangles);
    const double buildMs = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();

    std::mt19937_64 rng(11);
    std::vector<glm::dvec3> pts(exactPoints);
    for (auto& p : pts) p = randomIn(rng, lo, hi);
    const std::vector<double> exact = exactValues(w, pts);
    const Agreement a = compareFast(w, pts, exact);
    size_t parityAgree = 0;
    for (size_t i = 0; i < pts.size(); ++i)
        if (std::abs(exact[i] - 0.5) > 0.2) parityAgree += w.parityInside(pts[i]) == (exact[i] > 0.5);

    std::vector<glm::dvec3> timing(20000);
    for (auto& p : timing) p = randomIn(rng, lo, hi);
    double sink = 0;
    const auto t1 = Clock::now();
    for (const glm::dvec3& p : timing) sink += w.fast(p);
    const double fastNs =
        std::chrono::duration<double, std::nano>(Clock::now() - t1).count() / double(timing.size());
    const auto t2 = Clock::now();
    for (size_t i = 0; i < timing.size() / 10; ++i) sink += w.parityInside(timing[i]) ? 1 : 0;
    const double parityNs =
        std::chrono::duration<double, std::nano>(Clock::now() - t2).count() / double(timing.size() / 10);

    std::printf(
        "[winding] %s: %zu triangles, build %.1f ms; %zu random points in the padded box, %zu with "
        "|w-0.5|>0.2: "
        "fast sign agreement %.3f %%, max |fast-exact| %.4f, mean %.5f; parity agreement %.3f %%; fast %.0f "
        "ns/query, "
        "parity %.0f ns/query (%g)\n",
        name.c_str(), m.triangles.size(), buildMs, a.points, a.considered, 100.0 * a.rate(), a.maxError,
        a.meanError, a.considered ? 100.0 * double(parityAgree) / double(a.considered) : 100.0, fastNs,
        parityNs, sink);
    testing::Test::RecordProperty("fast_sign_agreement_percent", std::to_string(100.0 * a.rate()));
    testing::Test::RecordProperty("fast_max_error", std::to_string(a.maxError));
    testing::Test::RecordProperty(
        "parity_agreement_percent",
        std::to_string(a.considered ? 100.0 * double(parityAgree) / double(a.considered) : 100.0));
    EXPECT_GE(a.rate(), 0.999) << name;
    EXPECT_LT(a.maxError, 0.2) << name;
}

TEST(WindingRealMeshes, TeapotOpen) { checkRealMesh("teapot.ply", 2000); }
TEST(WindingRealMeshes, DragonRes4NonManifold) { checkRealMesh("dragon_vrip_res4.ply", 2000); }
// exact() costs ~20 ms per point on 871k triangles here: 300 points (on two threads).
TEST(WindingRealMeshes, DragonFull) { checkRealMesh("dragon_vrip.ply", 300); }

}  // namespace
}  // namespace penumbra::sdf
