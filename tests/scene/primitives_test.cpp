// Procedural primitive meshes: counts, normals (unit, outward), winding (counter-clockwise seen
// from outside), watertightness after merging vertices at identical positions, parameter checks,
// asset keys.
#include <cmath>
#include <map>
#include <tuple>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/assets/primitives.h"

namespace penumbra::assets {
namespace {

// Unit length within 1e-5 (float rounding of sin/cos products).
void expectUnitNormals(const MeshData& m) {
    ASSERT_EQ(m.normals.size(), m.positions.size());
    for (size_t i = 0; i < m.normals.size(); ++i) {
        ASSERT_NEAR(glm::length(m.normals[i]), 1.0f, 1e-5f) << "normal " << i;
    }
}

// Every normal points away from the shape's centre (dot > 0). For the torus the "centre" of a
// vertex is the nearest point of the ring circle, passed in through `centreOf`.
template <typename CentreOf>
void expectOutwardNormals(const MeshData& m, CentreOf centreOf) {
    for (size_t i = 0; i < m.positions.size(); ++i) {
        const glm::vec3 c = centreOf(m.positions[i]);
        ASSERT_GT(glm::dot(m.normals[i], m.positions[i] - c), 0.0f) << "vertex " << i;
    }
}

// Counter-clockwise seen from outside: the geometric normal cross(b - a, c - a) of every
// non-degenerate triangle agrees with its vertex normals (dot > 0) and with the outward direction.
template <typename CentreOf>
void expectCounterClockwise(const MeshData& m, CentreOf centreOf) {
    for (size_t t = 0; t < m.triangleCount(); ++t) {
        const uint32_t ia = m.indices[3 * t], ib = m.indices[3 * t + 1], ic = m.indices[3 * t + 2];
        const glm::vec3 a = m.positions[ia], b = m.positions[ib], c = m.positions[ic];
        const glm::vec3 n = glm::cross(b - a, c - a);
        ASSERT_GT(glm::length(n), 0.0f) << "degenerate triangle " << t;
        const glm::vec3 mid = (a + b + c) / 3.0f;
        EXPECT_GT(glm::dot(n, mid - centreOf(mid)), 0.0f) << "triangle " << t << " faces inward";
        EXPECT_GT(glm::dot(n, m.normals[ia] + m.normals[ib] + m.normals[ic]), 0.0f) << "triangle " << t;
    }
}

// Merges vertices at bit-identical positions, then counts how many triangles use each undirected
// edge. Watertight: every edge exactly twice. Also checks that each directed edge appears once
// (consistent orientation across neighbours).
void expectWatertight(const MeshData& m) {
    std::map<std::tuple<float, float, float>, uint32_t> weld;
    std::vector<uint32_t> id(m.positions.size());
    for (size_t i = 0; i < m.positions.size(); ++i) {
        const auto key = std::make_tuple(m.positions[i].x, m.positions[i].y, m.positions[i].z);
        id[i] = weld.emplace(key, uint32_t(weld.size())).first->second;
    }
    std::map<std::pair<uint32_t, uint32_t>, int> undirected, directed;
    for (size_t t = 0; t < m.triangleCount(); ++t) {
        for (int k = 0; k < 3; ++k) {
            const uint32_t a = id[m.indices[3 * t + k]];
            const uint32_t b = id[m.indices[3 * t + (k + 1) % 3]];
            ASSERT_NE(a, b) << "triangle " << t << " has a collapsed edge after welding";
            ++undirected[{std::min(a, b), std::max(a, b)}];
            ++directed[{a, b}];
        }
    }
    for (const auto& [edge, n] : undirected) {
        ASSERT_EQ(n, 2) << "edge " << edge.first << "-" << edge.second;
    }
    for (const auto& [edge, n] : directed) {
        ASSERT_EQ(n, 1) << "directed edge " << edge.first << "->" << edge.second << " (inconsistent winding)";
    }
}

// V - E + F of the surface after welding: 2 for a sphere-like surface, 0 for a torus.
long eulerCharacteristic(const MeshData& m) {
    std::map<std::tuple<float, float, float>, uint32_t> weld;
    std::vector<uint32_t> id(m.positions.size());
    for (size_t i = 0; i < m.positions.size(); ++i) {
        id[i] = weld.emplace(std::make_tuple(m.positions[i].x, m.positions[i].y, m.positions[i].z),
                             uint32_t(weld.size()))
                    .first->second;
    }
    std::map<std::pair<uint32_t, uint32_t>, int> edges;
    for (size_t t = 0; t < m.triangleCount(); ++t) {
        for (int k = 0; k < 3; ++k) {
            const uint32_t a = id[m.indices[3 * t + k]], b = id[m.indices[3 * t + (k + 1) % 3]];
            ++edges[{std::min(a, b), std::max(a, b)}];
        }
    }
    return long(weld.size()) - long(edges.size()) + long(m.triangleCount());
}

void expectUvsInUnitSquare(const MeshData& m) {
    ASSERT_EQ(m.uvs.size(), m.positions.size());
    for (const glm::vec2& uv : m.uvs) {
        ASSERT_GE(uv.x, 0.0f);
        ASSERT_LE(uv.x, 1.0f);
        ASSERT_GE(uv.y, 0.0f);
        ASSERT_LE(uv.y, 1.0f);
    }
}

const auto kOrigin = [](glm::vec3) { return glm::vec3(0.0f); };

TEST(Primitives, SphereCountsNormalsWindingWatertight) {
    MeshData m;
    std::string error;
    ASSERT_TRUE(makeSphere(0.75f, 24, 12, m, error)) << error;
    EXPECT_EQ(m.positions.size(), size_t(25 * 13));
    EXPECT_EQ(m.triangleCount(), size_t(2 * 24 * 11));
    for (const glm::vec3& p : m.positions) {
        ASSERT_NEAR(glm::length(p), 0.75f, 1e-5f);  // every vertex on the sphere (float rounding)
    }
    expectUnitNormals(m);
    expectOutwardNormals(m, kOrigin);
    expectCounterClockwise(m, kOrigin);
    expectWatertight(m);
    EXPECT_EQ(eulerCharacteristic(m), 2);
    expectUvsInUnitSquare(m);
    std::string why;
    EXPECT_TRUE(validateMesh(m, "sphere", why)) << why;
}

TEST(Primitives, SmallestSphereIsWatertight) {
    MeshData m;
    std::string error;
    ASSERT_TRUE(makeSphere(1.0f, 3, 2, m, error)) << error;
    EXPECT_EQ(m.triangleCount(), size_t(6));
    expectCounterClockwise(m, kOrigin);
    expectWatertight(m);
    EXPECT_EQ(eulerCharacteristic(m), 2);
}

TEST(Primitives, BoxCountsNormalsWindingWatertight) {
    MeshData m;
    std::string error;
    const glm::vec3 h(1.0f, 0.5f, 0.25f);
    ASSERT_TRUE(makeBox(h, m, error)) << error;
    EXPECT_EQ(m.positions.size(), size_t(24));
    EXPECT_EQ(m.triangleCount(), size_t(12));
    for (const glm::vec3& p : m.positions) {
        EXPECT_FLOAT_EQ(std::abs(p.x), h.x);
        EXPECT_FLOAT_EQ(std::abs(p.y), h.y);
        EXPECT_FLOAT_EQ(std::abs(p.z), h.z);
    }
    expectUnitNormals(m);
    expectOutwardNormals(m, kOrigin);
    // Flat faces: each normal is an axis and the vertex lies on that face.
    for (size_t i = 0; i < m.positions.size(); ++i) {
        EXPECT_FLOAT_EQ(glm::dot(m.normals[i], m.positions[i]), glm::dot(glm::abs(m.normals[i]), h));
    }
    expectCounterClockwise(m, kOrigin);
    expectWatertight(m);
    EXPECT_EQ(eulerCharacteristic(m), 2);
    expectUvsInUnitSquare(m);
}

TEST(Primitives, PlaneFacesUp) {
    MeshData m;
    std::string error;
    ASSERT_TRUE(makePlane(glm::vec2(2.0f, 3.0f), m, error)) << error;
    EXPECT_EQ(m.positions.size(), size_t(4));
    EXPECT_EQ(m.triangleCount(), size_t(2));
    for (size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(m.normals[i], glm::vec3(0, 1, 0));
        EXPECT_EQ(m.positions[i].y, 0.0f);
        EXPECT_FLOAT_EQ(std::abs(m.positions[i].x), 2.0f);
        EXPECT_FLOAT_EQ(std::abs(m.positions[i].z), 3.0f);
    }
    for (size_t t = 0; t < 2; ++t) {
        const glm::vec3 a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                        c = m.positions[m.indices[3 * t + 2]];
        EXPECT_GT(glm::cross(b - a, c - a).y, 0.0f)
            << "triangle " << t << " must be counter-clockwise seen from +Y";
    }
    expectUvsInUnitSquare(m);
}

TEST(Primitives, CylinderCountsNormalsWindingWatertight) {
    MeshData m;
    std::string error;
    ASSERT_TRUE(makeCylinder(0.5f, 1.0f, 16, m, error)) << error;
    EXPECT_EQ(m.positions.size(), size_t(4 * 17 + 2));
    EXPECT_EQ(m.triangleCount(), size_t(4 * 16));
    expectUnitNormals(m);
    // Side normals point away from the axis, cap normals away from the mid-plane.
    for (size_t i = 0; i < m.positions.size(); ++i) {
        const glm::vec3 p = m.positions[i], n = m.normals[i];
        if (std::abs(n.y) > 0.5f) {
            EXPECT_GT(n.y * p.y, 0.0f) << "cap vertex " << i;
        } else {
            EXPECT_GT(glm::dot(n, glm::vec3(p.x, 0.0f, p.z)), 0.0f) << "side vertex " << i;
            EXPECT_NEAR(glm::length(glm::vec2(p.x, p.z)), 0.5f, 1e-6f);
        }
    }
    expectCounterClockwise(m, kOrigin);
    expectWatertight(m);
    EXPECT_EQ(eulerCharacteristic(m), 2);
    expectUvsInUnitSquare(m);
}

TEST(Primitives, TorusCountsNormalsWindingWatertight) {
    MeshData m;
    std::string error;
    const float major = 1.0f, minor = 0.25f;
    ASSERT_TRUE(makeTorus(major, minor, 32, 12, m, error)) << error;
    EXPECT_EQ(m.positions.size(), size_t(33 * 13));
    EXPECT_EQ(m.triangleCount(), size_t(2 * 32 * 12));
    expectUnitNormals(m);
    // The tube centre nearest to p: the ring circle point in p's direction.
    const auto ringPoint = [major](glm::vec3 p) {
        const glm::vec2 xz(p.x, p.z);
        const glm::vec2 d = xz / glm::length(xz);
        return glm::vec3(major * d.x, 0.0f, major * d.y);
    };
    for (const glm::vec3& p : m.positions) {
        ASSERT_NEAR(glm::length(p - ringPoint(p)), minor, 1e-5f);  // on the tube surface
    }
    expectOutwardNormals(m, ringPoint);
    expectCounterClockwise(m, ringPoint);
    expectWatertight(m);
    EXPECT_EQ(eulerCharacteristic(m), 0);
    expectUvsInUnitSquare(m);
}

TEST(Primitives, ParametersAreValidated) {
    MeshData m;
    std::string error;
    const float nan = std::nanf("");
    const float inf = INFINITY;
    EXPECT_FALSE(makeSphere(0.0f, 8, 4, m, error));
    EXPECT_NE(error.find("sphere: radius"), std::string::npos) << error;
    EXPECT_FALSE(makeSphere(-1.0f, 8, 4, m, error));
    EXPECT_FALSE(makeSphere(nan, 8, 4, m, error));
    EXPECT_FALSE(makeSphere(inf, 8, 4, m, error));
    EXPECT_FALSE(makeSphere(1.0f, 2, 4, m, error));
    EXPECT_NE(error.find("segments must be in [3, 1024] (got 2)"), std::string::npos) << error;
    EXPECT_FALSE(makeSphere(1.0f, 8, 1, m, error));
    EXPECT_NE(error.find("rings must be in [2, 1024] (got 1)"), std::string::npos) << error;
    EXPECT_FALSE(makeSphere(1.0f, 1025, 4, m, error));
    EXPECT_FALSE(makeBox(glm::vec3(1.0f, 0.0f, 1.0f), m, error));
    EXPECT_NE(error.find("box: halfExtents.y"), std::string::npos) << error;
    EXPECT_FALSE(makeBox(glm::vec3(1.0f, 1.0f, nan), m, error));
    EXPECT_FALSE(makePlane(glm::vec2(1.0f, -2.0f), m, error));
    EXPECT_NE(error.find("plane: halfSize.z"), std::string::npos) << error;
    EXPECT_FALSE(makeCylinder(1.0f, 0.0f, 8, m, error));
    EXPECT_NE(error.find("cylinder: halfHeight"), std::string::npos) << error;
    EXPECT_FALSE(makeCylinder(1.0f, 1.0f, 0, m, error));
    EXPECT_FALSE(makeTorus(1.0f, 1.0f, 8, 8, m, error));
    EXPECT_NE(error.find("minorRadius (1) must be smaller than majorRadius (1)"), std::string::npos) << error;
    EXPECT_FALSE(makeTorus(1.0f, 0.5f, 8, 2, m, error));
    EXPECT_NE(error.find("torus: sides"), std::string::npos) << error;
    EXPECT_TRUE(m.positions.empty()) << "a failed build must not touch the output";
    EXPECT_FALSE(makeSphere(1e30f, 8, 4, m, error));  // beyond the documented 1e18 length cap
}

TEST(Primitives, ShapeNamesRoundTrip) {
    for (PrimitiveShape s : {PrimitiveShape::Sphere, PrimitiveShape::Box, PrimitiveShape::Plane,
                             PrimitiveShape::Cylinder, PrimitiveShape::Torus}) {
        PrimitiveShape back = PrimitiveShape::Sphere;
        ASSERT_TRUE(parsePrimitiveShape(primitiveShapeName(s), back));
        EXPECT_EQ(back, s);
    }
    PrimitiveShape out;
    EXPECT_FALSE(parsePrimitiveShape("cone", out));
}

TEST(Primitives, KeysNameTheShapeParametersOnly) {
    PrimitiveDesc sphere;
    sphere.shape = PrimitiveShape::Sphere;
    sphere.radius = 0.5f;
    sphere.segments = 32;
    sphere.rings = 16;
    EXPECT_EQ(primitiveKey(sphere), "primitive:sphere:r=0.5:seg=32:rings=16");
    PrimitiveDesc other = sphere;
    other.halfExtents = glm::vec3(3.0f);  // not a sphere parameter: same key
    EXPECT_EQ(primitiveKey(other), primitiveKey(sphere));
    other.rings = 17;
    EXPECT_NE(primitiveKey(other), primitiveKey(sphere));
    PrimitiveDesc box;
    box.shape = PrimitiveShape::Box;
    box.halfExtents = glm::vec3(1.0f, 0.5f, 0.25f);
    EXPECT_EQ(primitiveKey(box), "primitive:box:h=1,0.5,0.25");
    PrimitiveDesc torus;
    torus.shape = PrimitiveShape::Torus;
    EXPECT_EQ(primitiveKey(torus).rfind("primitive:torus:", 0), 0u);
    // 0.1f prints in its shortest round-trip form, so distinct floats never share a key.
    PrimitiveDesc a = sphere, b = sphere;
    a.radius = 0.1f;
    b.radius = std::nextafter(0.1f, 1.0f);
    EXPECT_NE(primitiveKey(a), primitiveKey(b));
}

TEST(Primitives, IdenticalPrimitivesShareOneAsset) {
    AssetManager assets;
    PrimitiveDesc d;
    d.shape = PrimitiveShape::Cylinder;
    MeshData m1, m2;
    std::string error;
    ASSERT_TRUE(makePrimitive(d, m1, error)) << error;
    ASSERT_TRUE(makePrimitive(d, m2, error)) << error;
    const AssetId a = assets.addMesh(primitiveKey(d), std::move(m1), error);
    const AssetId b = assets.addMesh(primitiveKey(d), std::move(m2), error);
    ASSERT_NE(a, 0u) << error;
    EXPECT_EQ(a, b);
    EXPECT_EQ(assets.refCount(a), 2u);
    EXPECT_EQ(assets.count(), 1u);
}

}  // namespace
}  // namespace penumbra::assets
