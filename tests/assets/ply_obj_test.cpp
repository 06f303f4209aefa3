// PLY and OBJ loading of hand-written files (all PLY encodings, property types, polygons, skipped
// elements) and writer round trips.
#include <cstring>
#include <random>

#include <gtest/gtest.h>
#include <glm/glm.hpp>

#include "assets/assets_test_util.h"
#include "engine/assets/mesh.h"

namespace penumbra::assets {
namespace {

template <typename T>
void putLe(std::string& s, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s.append(b, sizeof(T));
}

template <typename T>
void putBe(std::string& s, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (size_t i = sizeof(T); i-- > 0;) {
        s.push_back(b[i]);
    }
}

void expectVec(const glm::vec3& a, const glm::vec3& b) {
    EXPECT_FLOAT_EQ(a.x, b.x);
    EXPECT_FLOAT_EQ(a.y, b.y);
    EXPECT_FLOAT_EQ(a.z, b.z);
}

// A unit square split by a quad face plus a triangle, with extra elements and properties that must
// be skipped: a vertex list property, a leading scalar, and an unknown element with lists.
const char* kAsciiSquare =
    "ply\r\n"
    "format ascii 1.0\r\n"
    "comment made by hand\r\n"
    "obj_info nothing\r\n"
    "element material 2\r\n"
    "property list uchar float weights\r\n"
    "property uchar id\r\n"
    "element vertex 5\r\n"
    "property uchar flags\r\n"
    "property double x\r\n"
    "property float y\r\n"
    "property int z\r\n"
    "property list ushort int junk\r\n"
    "property float nx\r\n"
    "property float ny\r\n"
    "property float nz\r\n"
    "property float s\r\n"
    "property float t\r\n"
    "element face 2\r\n"
    "property uchar before\r\n"
    "property list uchar uint vertex_index\r\n"
    "property list int short after\r\n"
    "end_header\r\n"
    "3 0.5 1 2 7\r\n"
    "0 1\r\n"
    "7 0 0 0 0 0 0 1 0 0\r\n"
    "7 1 0 0 2 5 5 0 0 1 1 0\r\n"
    "7 1 1 0 0 0 0 1 1 1\r\n"
    "7 0.0 +1.0 0 1 9 0 0 1 0 1\r\n"
    "7 2.5e0 1 -3 0 0 0 1 0.5 0.5\r\n"
    "9 4 0 1 2 3 2 1 1\r\n"
    "9 3 1 4 2 0\r\n";

TEST(Ply, AsciiWithSkippedElementsPropertiesAndPolygons) {
    test::TempDir dir;
    const std::string path = dir.write("square.ply", kAsciiSquare);
    MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadPly(path, mesh, error)) << error;
    ASSERT_EQ(mesh.positions.size(), 5u);
    expectVec(mesh.positions[0], {0, 0, 0});
    expectVec(mesh.positions[3], {0, 1, 0});
    expectVec(mesh.positions[4], {2.5f, 1, -3});
    ASSERT_EQ(mesh.normals.size(), 5u);
    expectVec(mesh.normals[1], {0, 0, 1});
    ASSERT_EQ(mesh.uvs.size(), 5u);
    EXPECT_FLOAT_EQ(mesh.uvs[2].x, 1.0f);
    EXPECT_FLOAT_EQ(mesh.uvs[4].y, 0.5f);
    // The quad is fanned from its first vertex; the triangle follows.
    const std::vector<uint32_t> expected = {0, 1, 2, 0, 2, 3, 1, 4, 2};
    EXPECT_EQ(mesh.indices, expected);
}

std::string binaryHeader(const char* format) {
    return std::string("ply\nformat ") + format +
           " 1.0\n"
           "element vertex 4\n"
           "property short flags\n"
           "property float x\nproperty float y\nproperty double z\n"
           "property list uchar float extra\n"
           "element edge 1\nproperty list uint uchar ends\nproperty int weight\n"
           "element face 2\nproperty list int ushort vertex_indices\nproperty float quality\n"
           "end_header\n";
}

template <bool BigEndian>
std::string binaryBody() {
    std::string s;
    auto put = [&](auto v) {
        if constexpr (BigEndian) {
            putBe(s, v);
        } else {
            putLe(s, v);
        }
    };
    const float xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.25f}, {0, 1, -1e-3f}};
    for (int v = 0; v < 4; ++v) {
        put(int16_t(-v));
        put(xyz[v][0]);
        put(xyz[v][1]);
        put(double(xyz[v][2]));
        put(uint8_t(v % 2));
        for (int k = 0; k < v % 2; ++k) {
            put(1.5f);
        }
    }
    put(uint32_t(2));
    put(uint8_t(0));
    put(uint8_t(3));
    put(int32_t(7));
    put(int32_t(3));
    put(uint16_t(0));
    put(uint16_t(1));
    put(uint16_t(2));
    put(0.5f);
    put(int32_t(3));
    put(uint16_t(0));
    put(uint16_t(2));
    put(uint16_t(3));
    put(0.5f);
    return s;
}

TEST(Ply, BinaryLittleAndBigEndianAgree) {
    test::TempDir dir;
    const std::string le = dir.write("le.ply", binaryHeader("binary_little_endian") + binaryBody<false>());
    const std::string be = dir.write("be.ply", binaryHeader("binary_big_endian") + binaryBody<true>());
    MeshData a, b;
    std::string error;
    ASSERT_TRUE(loadPly(le, a, error)) << error;
    ASSERT_TRUE(loadPly(be, b, error)) << error;
    ASSERT_EQ(a.positions.size(), 4u);
    expectVec(a.positions[2], {1, 1, 0.25f});
    expectVec(a.positions[3], {0, 1, -1e-3f});
    const std::vector<uint32_t> expected = {0, 1, 2, 0, 2, 3};
    EXPECT_EQ(a.indices, expected);
    EXPECT_EQ(b.indices, expected);
    for (size_t i = 0; i < 4; ++i) {
        expectVec(b.positions[i], a.positions[i]);
    }
    EXPECT_TRUE(a.normals.empty());
    EXPECT_TRUE(a.uvs.empty());
}

TEST(Ply, ExtensionIsCaseInsensitive) {
    test::TempDir dir;
    const std::string path = dir.write("SQUARE.PLY", kAsciiSquare);
    MeshData mesh;
    std::string error;
    EXPECT_TRUE(loadMesh(path, mesh, error)) << error;
}

MeshData randomMesh(bool normals, bool uvs) {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> coord(-1e3f, 1e3f);
    MeshData mesh;
    for (int i = 0; i < 300; ++i) {
        mesh.positions.emplace_back(coord(rng), coord(rng) * 1e-6f, coord(rng));
        if (normals) {
            mesh.normals.push_back(glm::normalize(glm::vec3(coord(rng), coord(rng), coord(rng))));
        }
        if (uvs) {
            mesh.uvs.emplace_back(coord(rng) / 1e3f, coord(rng));
        }
    }
    std::uniform_int_distribution<uint32_t> index(0, 299);
    for (uint32_t t = 0; t < 500 * 3; ++t) {
        mesh.indices.push_back(t < 300 ? t : index(rng));  // every vertex referenced
    }
    return mesh;
}

void expectSameMesh(const MeshData& a, const MeshData& b) {
    ASSERT_EQ(a.positions.size(), b.positions.size());
    ASSERT_EQ(a.normals.size(), b.normals.size());
    ASSERT_EQ(a.uvs.size(), b.uvs.size());
    EXPECT_EQ(a.indices, b.indices);
    for (size_t i = 0; i < a.positions.size(); ++i) {
        ASSERT_EQ(a.positions[i], b.positions[i]) << "vertex " << i;
    }
    for (size_t i = 0; i < a.normals.size(); ++i) {
        ASSERT_EQ(a.normals[i], b.normals[i]) << "normal " << i;
    }
    for (size_t i = 0; i < a.uvs.size(); ++i) {
        ASSERT_EQ(a.uvs[i], b.uvs[i]) << "uv " << i;
    }
}

class RoundTrip : public testing::TestWithParam<std::tuple<bool, bool>> {};

TEST_P(RoundTrip, WritePlyThenLoadPlyIsExact) {
    const auto [normals, uvs] = GetParam();
    const MeshData mesh = randomMesh(normals, uvs);
    test::TempDir dir;
    const std::string path = dir.file("rt.ply");
    std::string error;
    ASSERT_TRUE(writePly(path, mesh, error)) << error;
    MeshData back;
    ASSERT_TRUE(loadPly(path, back, error)) << error;
    expectSameMesh(mesh, back);
}

TEST_P(RoundTrip, WriteObjThenLoadObj) {
    const auto [normals, uvs] = GetParam();
    const MeshData mesh = randomMesh(normals, uvs);
    test::TempDir dir;
    const std::string path = dir.file("rt.obj");
    std::string error;
    ASSERT_TRUE(writeObj(path, mesh, error)) << error;
    MeshData back;
    ASSERT_TRUE(loadObj(path, back, error)) << error;
    // tinyobjloader's number parser is not always correctly rounded: allow one float ulp or so.
    ASSERT_EQ(back.positions.size(), mesh.positions.size());
    ASSERT_EQ(back.normals.size(), mesh.normals.size());
    ASSERT_EQ(back.uvs.size(), mesh.uvs.size());
    EXPECT_EQ(back.indices, mesh.indices);
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
        for (int a = 0; a < 3; ++a) {
            ASSERT_NEAR(back.positions[i][a], mesh.positions[i][a], std::abs(mesh.positions[i][a]) * 2e-7f)
                << "vertex " << i;
        }
    }
    for (size_t i = 0; i < mesh.normals.size(); ++i) {
        for (int a = 0; a < 3; ++a) {
            ASSERT_NEAR(back.normals[i][a], mesh.normals[i][a], 1e-6f) << "normal " << i;
        }
    }
    for (size_t i = 0; i < mesh.uvs.size(); ++i) {
        for (int a = 0; a < 2; ++a) {
            ASSERT_NEAR(back.uvs[i][a], mesh.uvs[i][a], std::abs(mesh.uvs[i][a]) * 2e-7f + 1e-9f)
                << "uv " << i;
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Attributes, RoundTrip, testing::Combine(testing::Bool(), testing::Bool()),
                         [](const testing::TestParamInfo<std::tuple<bool, bool>>& info) {
                             return std::string(std::get<0>(info.param) ? "Normals" : "NoNormals") +
                                    (std::get<1>(info.param) ? "Uvs" : "NoUvs");
                         });

TEST(Writers, RefuseInvalidMeshesAndUnwritablePaths) {
    test::TempDir dir;
    MeshData mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    mesh.indices = {0, 1, 3};
    std::string error;
    EXPECT_FALSE(writePly(dir.file("bad.ply"), mesh, error));
    EXPECT_NE(error.find("out of range"), std::string::npos) << error;
    EXPECT_FALSE(writeObj(dir.file("bad.obj"), mesh, error));
    EXPECT_NE(error.find("out of range"), std::string::npos) << error;
    mesh.indices = {0, 1, 2};
    EXPECT_FALSE(writePly("/proc/penumbra/none.ply", mesh, error));
    EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
    EXPECT_FALSE(writeObj(dir.file("no/such/dir.obj"), mesh, error));
    EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
}

TEST(Obj, PolygonsAreFanTriangulatedAndAttributesKept) {
    test::TempDir dir;
    const std::string path =
        dir.write("poly.obj",
                  "# pentagon + triangle, with a material library that must not be read\n"
                  "mtllib ../../../etc/passwd\n"
                  "o thing\n"
                  "v 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 2 0\nv -0.5 1 0\nv 0 0 1\n"
                  "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\nvt 0.2 0.2\n"
                  "vn 0 0 1\nvn 0 0 -1\n"
                  "usemtl red\n"
                  "f 1/1/1 2/2/1 3/3/1 4/4/1 5/5/1\n"
                  "g second\n"
                  "f -6/6/2 -5/2/2 -1/6/2\n"
                  "l 1 2\n");
    MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadObj(path, mesh, error)) << error;
    ASSERT_EQ(mesh.positions.size(), 6u);
    const std::vector<uint32_t> expected = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 1, 5};
    EXPECT_EQ(mesh.indices, expected);
    ASSERT_EQ(mesh.normals.size(), 6u);
    expectVec(mesh.normals[0], {0, 0, 1});
    expectVec(mesh.normals[5], {0, 0, -1});
    ASSERT_EQ(mesh.uvs.size(), 6u);
    EXPECT_FLOAT_EQ(mesh.uvs[4].x, 0.5f);
}

TEST(Obj, CornersWithoutNormalsDropNormals) {
    test::TempDir dir;
    const std::string path = dir.write("mixed.obj",
                                       "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\n"
                                       "f 1//1 2//1 3//1\nf 2 4 3\n");
    MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadObj(path, mesh, error)) << error;
    EXPECT_EQ(mesh.triangleCount(), 2u);
    EXPECT_TRUE(mesh.normals.empty());
    EXPECT_TRUE(mesh.uvs.empty());
}

}  // namespace
}  // namespace penumbra::assets
