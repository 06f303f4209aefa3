// The STL importer plugin, loaded with dlopen: binary and ASCII files written here, and malformed
// files that must be refused with a clear message naming the file.
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/plugin/plugin_host.h"
#include "plugin/plugin_test_util.h"

namespace {

using namespace penumbra;
using test::LogCapture;
using test::PluginTempDir;

struct Tri {
    glm::vec3 a, b, c;
};

// The 12 triangles of the unit cube (8 distinct corners).
std::vector<Tri> cube() {
    const glm::vec3 p[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                            {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    const int quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                             {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};
    std::vector<Tri> tris;
    for (const auto& q : quads) {
        tris.push_back({p[q[0]], p[q[1]], p[q[2]]});
        tris.push_back({p[q[0]], p[q[2]], p[q[3]]});
    }
    return tris;
}

void appendU32(std::string& s, uint32_t v) {
    for (int i = 0; i < 4; ++i) s.push_back(char((v >> (8 * i)) & 0xff));
}
void appendF32(std::string& s, float f) {
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    appendU32(s, bits);
}

std::string binaryStl(const std::vector<Tri>& tris, const std::string& header = "penumbra test",
                      uint32_t claimedCount = std::numeric_limits<uint32_t>::max()) {
    std::string s = header;
    s.resize(80, ' ');
    appendU32(s, claimedCount == std::numeric_limits<uint32_t>::max() ? uint32_t(tris.size()) : claimedCount);
    for (const Tri& t : tris) {
        for (float f : {0.f, 0.f, 1.f}) appendF32(s, f);
        for (const glm::vec3& v : {t.a, t.b, t.c}) {
            appendF32(s, v.x);
            appendF32(s, v.y);
            appendF32(s, v.z);
        }
        s.append(2, '\0');
    }
    return s;
}

std::string asciiStl(const std::vector<Tri>& tris) {
    std::string s = "solid cube exported by the test\n";
    for (const Tri& t : tris) {
        s += "  facet normal 0 0 1\n    outer loop\n";
        for (const glm::vec3& v : {t.a, t.b, t.c}) {
            s += "      vertex " + std::to_string(v.x) + " " + std::to_string(v.y) + " " +
                 std::to_string(v.z) + "\n";
        }
        s += "    endloop\n  endfacet\n";
    }
    s += "endsolid cube\n";
    return s;
}

class StlImporter : public testing::Test {
protected:
    void SetUp() override {
        ASSERT_TRUE(m_host.loadLibrary(test::pluginPath("stl_importer"))) << m_host.lastError();
    }

    // Imports; on failure returns the message (empty on success).
    std::string importError(const std::string& name, const std::string& bytes) {
        const std::string path = m_dir.write(name, bytes);
        std::string error;
        const bool ok = m_host.importMesh(path, m_mesh, error);
        if (ok) return {};
        EXPECT_FALSE(error.empty());
        EXPECT_EQ(error.rfind(path, 0), 0u) << "message does not start with the file: " << error;
        EXPECT_TRUE(m_mesh.positions.empty() && m_mesh.indices.empty()) << "partial mesh left behind";
        return error;
    }

    LogCapture m_capture;
    PluginTempDir m_dir;
    plugin::PluginHost m_host;
    assets::MeshData m_mesh;
};

TEST_F(StlImporter, BinaryCube) {
    ASSERT_EQ(importError("cube.stl", binaryStl(cube())), "");
    EXPECT_EQ(m_mesh.triangleCount(), 12u);
    EXPECT_EQ(m_mesh.positions.size(), 8u);  // corners welded
    EXPECT_TRUE(m_mesh.normals.empty());
    // Winding kept: the first triangle is corners 0, 3, 2.
    EXPECT_EQ(m_mesh.positions[m_mesh.indices[0]], glm::vec3(0, 0, 0));
    EXPECT_EQ(m_mesh.positions[m_mesh.indices[1]], glm::vec3(0, 1, 0));
    EXPECT_EQ(m_mesh.positions[m_mesh.indices[2]], glm::vec3(1, 1, 0));
}

TEST_F(StlImporter, BinaryWhoseHeaderStartsWithSolid) {
    ASSERT_EQ(
        importError("solid_header.stl", binaryStl(cube(), "solid binary file with an ascii-looking header")),
        "");
    EXPECT_EQ(m_mesh.triangleCount(), 12u);
}

TEST_F(StlImporter, AsciiCubeAndUpperCaseExtension) {
    ASSERT_EQ(importError("cube.STL", asciiStl(cube())), "");
    EXPECT_EQ(m_mesh.triangleCount(), 12u);
    EXPECT_EQ(m_mesh.positions.size(), 8u);
}

TEST_F(StlImporter, AsciiVariants) {
    // Upper-case keywords, CRLF, '+' signs, exponents, two solids, a quad (fanned into 2 triangles).
    const std::string text =
        "SOLID a\r\nFACET NORMAL 0 0 1\r\nOUTER LOOP\r\nVERTEX 0 0 0\r\nVERTEX +1e0 0 0\r\nVERTEX 0 1.0E+00 "
        "-0\r\n"
        "ENDLOOP\r\nENDFACET\r\nENDSOLID a\r\n"
        "solid b\nfacet normal 0 0 0\nouter loop\nvertex 0 0 1\nvertex 1 0 1\nvertex 1 1 1\nvertex 0 1 1\n"
        "endloop\nendfacet\nendsolid\n";
    ASSERT_EQ(importError("variants.stl", text), "");
    EXPECT_EQ(m_mesh.triangleCount(), 3u);
    EXPECT_EQ(m_mesh.positions.size(), 7u);
}

TEST_F(StlImporter, RefusesTruncatedBinary) {
    std::string bytes = binaryStl(cube());
    bytes.resize(bytes.size() - 7);
    const std::string error = importError("truncated.stl", bytes);
    EXPECT_NE(
        error.find("truncated binary STL: the header claims 12 triangles (684 bytes) but the file has 677"),
        std::string::npos)
        << error;
}

TEST_F(StlImporter, RefusesShortHeader) {
    const std::string error = importError("short.stl", std::string(40, '\x01'));
    EXPECT_NE(error.find("40 bytes, the header and triangle count alone need 84"), std::string::npos)
        << error;
}

TEST_F(StlImporter, RefusesHugeTriangleCount) {
    // 2^31 triangles claimed by a file of a few hundred bytes: refused before allocating.
    const std::string error = importError("huge.stl", binaryStl(cube(), "x", 0x80000000u));
    EXPECT_NE(error.find("claims 2147483648 triangles, over the limit"), std::string::npos) << error;
    const std::string error2 = importError("many.stl", binaryStl(cube(), "x", 1000));
    EXPECT_NE(error2.find("claims 1000 triangles (50084 bytes) but the file has 684 bytes"),
              std::string::npos)
        << error2;
}

TEST_F(StlImporter, RefusesTrailingBytesAndZeroTriangles) {
    std::string bytes = binaryStl(cube());
    bytes.append(10, '\0');
    EXPECT_NE(importError("trailing.stl", bytes).find("10 bytes after its last triangle"), std::string::npos);
    EXPECT_NE(importError("zero.stl", binaryStl({})).find("no triangles"), std::string::npos);
}

TEST_F(StlImporter, RefusesNonFiniteCoordinates) {
    std::vector<Tri> tris = cube();
    tris[5].b.y = std::numeric_limits<float>::quiet_NaN();
    const std::string error = importError("nan.stl", binaryStl(tris));
    EXPECT_NE(error.find("triangle 5 vertex 1: non-finite coordinate"), std::string::npos) << error;

    tris = cube();
    tris[0].c.z = std::numeric_limits<float>::infinity();
    EXPECT_NE(importError("inf.stl", binaryStl(tris)).find("non-finite"), std::string::npos);

    const std::string ascii =
        "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\nvertex 0 1 0\n"
        "endloop\nendfacet\nendsolid s\n";
    const std::string asciiError = importError("nan_ascii.stl", ascii);
    EXPECT_NE(asciiError.find("line 5: non-finite vertex coordinate 'nan'"), std::string::npos) << asciiError;
}

TEST_F(StlImporter, RefusesMalformedAscii) {
    const std::string head = "solid s\nfacet normal 0 0 1\nouter loop\n";
    struct Case {
        const char* name;
        std::string text;
        const char* expected;
    };
    const std::vector<Case> cases = {
        {"typo.stl", head + "vertx 0 0 0\n", "line 4: expected 'vertex' or 'endloop', found 'vertx'"},
        {"number.stl", head + "vertex 0 zero 0\n", "line 4: expected a number, found 'zero'"},
        {"partial_number.stl", head + "vertex 0 1.5abc 0\n", "expected a number, found '1.5abc'"},
        {"two_vertices.stl", head + "vertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n",
         "a facet with 2 vertices (needs 3)"},
        {"no_endsolid.stl", head + "vertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n",
         "expected 'facet' or 'endsolid', found end of file"},
        {"cut.stl", head + "vertex 0 0", "expected a number, found end of file"},
        {"no_endfacet.stl", head + "vertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nfacet\n",
         "expected 'endfacet', found 'facet'"},
        {"empty_solid.stl", "solid nothing\nendsolid nothing\n", "ASCII STL with no facets"},
        {"garbage_after.stl", "solid s\nendsolid s\nhello\n", "expected 'solid', found 'hello'"},
    };
    for (const Case& c : cases) {
        const std::string error = importError(c.name, c.text);
        EXPECT_NE(error.find(c.expected), std::string::npos) << c.name << ": " << error;
    }
}

TEST_F(StlImporter, RefusesMissingEmptyAndNonFiles) {
    std::string error;
    EXPECT_FALSE(m_host.importMesh(m_dir.file("absent.stl"), m_mesh, error));
    EXPECT_EQ(error, m_dir.file("absent.stl") + ": no such file");
    EXPECT_NE(importError("empty.stl", "").find("empty file"), std::string::npos);
    const std::string folder = m_dir.file("folder.stl");
    std::filesystem::create_directory(folder);
    EXPECT_FALSE(m_host.importMesh(folder, m_mesh, error));
    EXPECT_EQ(error, folder + ": not a regular file");
}

}  // namespace
