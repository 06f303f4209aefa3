// Hostile input: every file in tests/malformed/{ply,obj,gltf}/ must be refused with an error that
// names the file and the reason, without crashing (the suite also runs under ASan + UBSan).
#include <cctype>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "assets/assets_test_util.h"
#include "engine/assets/mesh.h"

namespace penumbra::assets {
namespace {

struct BadFile {
    const char* file;     // relative to tests/malformed/
    const char* keyword;  // must appear in the error
};

void PrintTo(const BadFile& b, std::ostream* os) { *os << b.file; }

class MalformedMesh : public testing::TestWithParam<BadFile> {};

TEST_P(MalformedMesh, IsRefusedWithAClearError) {
    const std::string path = test::sourcePath(std::string("tests/malformed/") + GetParam().file);
    ASSERT_TRUE(std::filesystem::is_regular_file(path)) << path;
    MeshData mesh;
    mesh.positions.resize(5);  // must be cleared on failure
    std::string error;
    EXPECT_FALSE(loadMesh(path, mesh, error));
    EXPECT_NE(error.find(path), std::string::npos) << "error does not name the file: " << error;
    EXPECT_NE(error.find(GetParam().keyword), std::string::npos)
        << "error lacks '" << GetParam().keyword << "': " << error;
    EXPECT_TRUE(mesh.positions.empty());
    EXPECT_TRUE(mesh.indices.empty());
}

const BadFile kBadFiles[] = {
    // PLY
    {"ply/truncated_binary.ply", "truncated"},
    {"ply/truncated_ascii.ply", "truncated"},
    {"ply/ascii_count_larger_than_file.ply", "larger than the file"},
    {"ply/bad_magic.ply", "bad magic"},
    {"ply/vertex_count_2pow31.ply", "larger than the file"},
    {"ply/face_count_huge.ply", "larger than the file"},
    {"ply/count_not_a_number.ply", "invalid count"},
    {"ply/negative_list_count.ply", "negative list count"},
    {"ply/huge_list_count.ply", "list count 4294967280 is larger than the rest of the file"},
    {"ply/ascii_list_count_out_of_range.ply", "out of range"},
    {"ply/index_out_of_range.ply", "vertex index 7 out of range"},
    {"ply/negative_index.ply", "vertex index -1 out of range"},
    {"ply/nan_vertex.ply", "non-finite"},
    {"ply/inf_vertex_binary.ply", "non-finite"},
    {"ply/float_overflow.ply", "finite"},
    {"ply/unknown_format.ply", "unknown PLY format"},
    {"ply/no_end_header.ply", "end_header"},
    {"ply/missing_z.ply", "no property 'z'"},
    {"ply/bad_number.ply", "invalid number"},
    {"ply/float_face_indices.ply", "integer"},
    {"ply/unknown_type.ply", "unknown property type"},
    {"ply/empty.ply", "empty"},
    // OBJ
    {"obj/face_index_out_of_range.obj", "out of range"},
    {"obj/negative_index_out_of_range.obj", "out of range"},
    {"obj/zero_index.obj", "OBJ"},
    {"obj/garbage.obj", "no faces"},
    {"obj/no_faces.obj", "no faces"},
    {"obj/inf_vertex.obj", "non-finite"},
    {"obj/empty.obj", "empty"},
    // glTF / GLB
    {"gltf/bad_json.gltf", "JSON"},
    {"gltf/deep_json.gltf", "nested deeper"},
    {"gltf/accessor_out_of_view.gltf", "out of range of bufferView"},
    {"gltf/view_out_of_buffer.gltf", "out of range of buffer"},
    {"gltf/stride_too_small.gltf", "byteStride"},
    {"gltf/offset_overflow.gltf", "out of range of bufferView"},
    {"gltf/huge_count.gltf", "exceeds the limit"},
    {"gltf/uri_parent_escape.gltf", "escapes the asset directory"},
    {"gltf/uri_percent_escape.gltf", "escapes the asset directory"},
    {"gltf/uri_absolute.gltf", "absolute path"},
    {"gltf/uri_scheme.gltf", "scheme"},
    {"gltf/uri_missing_file.gltf", "not found"},
    {"gltf/node_two_parents.gltf", "two parents"},
    {"gltf/node_cycle.gltf", "cycle"},
    {"gltf/node_self_child.gltf", "cycle"},
    {"gltf/node_child_out_of_range.gltf", "out of range"},
    {"gltf/index_out_of_range.gltf", "out of range"},
    {"gltf/position_not_float.gltf", "unsupported component type"},
    {"gltf/indices_float.gltf", "unsupported component type"},
    {"gltf/nan_position.gltf", "finite"},
    {"gltf/bad_mode.gltf", "mode"},
    {"gltf/no_position.gltf", "POSITION"},
    {"gltf/truncated.glb", "truncated"},
    {"gltf/bad_magic.glb", "bad magic"},
    {"gltf/json_chunk_too_long.glb", "JSON chunk"},
    {"gltf/bin_chunk_too_long.glb", "BIN chunk"},
    {"gltf/glb_buffer_length_zero.glb", "buffer 0 (the BIN chunk) has byteLength 0"},
    {"gltf/glb_buffer_longer_than_bin.glb", "at most the BIN chunk's 44 bytes"},
    {"gltf/glb_no_bin_chunk.glb", "buffer 0 has no uri"},
    {"gltf/scene_duplicate_roots.gltf", "node 0 is listed twice"},
    {"gltf/empty.gltf", "empty"},
};

INSTANTIATE_TEST_SUITE_P(Files, MalformedMesh, testing::ValuesIn(kBadFiles),
                         [](const testing::TestParamInfo<BadFile>& info) {
                             std::string name = info.param.file;
                             for (char& c : name) {
                                 if (!std::isalnum(static_cast<unsigned char>(c))) {
                                     c = '_';
                                 }
                             }
                             return name;
                         });

TEST(MalformedMesh, EveryFileInTheCorpusIsListed) {
    size_t files = 0;
    for (const char* dir : {"ply", "obj", "gltf"}) {
        for (const auto& entry :
             std::filesystem::directory_iterator(test::sourcePath(std::string("tests/malformed/") + dir))) {
            const std::string rel = std::string(dir) + "/" + entry.path().filename().string();
            bool listed = false;
            for (const BadFile& b : kBadFiles) {
                listed = listed || rel == b.file;
            }
            EXPECT_TRUE(listed) << rel << " is in tests/malformed but not in kBadFiles";
            ++files;
        }
    }
    EXPECT_EQ(files, std::size(kBadFiles));
    EXPECT_GE(files, 25u);
}

TEST(MalformedMesh, MissingFileIsReported) {
    for (const char* ext : {"ply", "obj", "gltf", "glb"}) {
        const std::string path = test::sourcePath(std::string("tests/malformed/does_not_exist.") + ext);
        MeshData mesh;
        std::string error;
        EXPECT_FALSE(loadMesh(path, mesh, error));
        EXPECT_NE(error.find(path), std::string::npos) << error;
        EXPECT_NE(error.find("No such file"), std::string::npos) << error;
    }
}

TEST(MalformedMesh, DirectoryInsteadOfFileIsReported) {
    test::TempDir dir;
    for (const char* ext : {"ply", "obj", "gltf", "glb"}) {
        const std::string path = dir.file(std::string("folder.") + ext);
        std::filesystem::create_directory(path);
        MeshData mesh;
        std::string error;
        EXPECT_FALSE(loadMesh(path, mesh, error));
        EXPECT_NE(error.find(path), std::string::npos) << error;
        EXPECT_NE(error.find("directory"), std::string::npos) << error;
    }
}

TEST(MalformedMesh, UnknownExtensionIsReported) {
    test::TempDir dir;
    const std::string path = dir.write("mesh.stl", "solid x\nendsolid x\n");
    MeshData mesh;
    std::string error;
    EXPECT_FALSE(loadMesh(path, mesh, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("unknown mesh format"), std::string::npos) << error;
}

TEST(MalformedMesh, VertexCountIsCheckedAgainstTheFileEvenWithoutLimits) {
    MeshLoadLimits unlimited;
    unlimited.maxVertices = UINT64_MAX;
    unlimited.maxTriangles = UINT64_MAX;
    const std::string path = test::sourcePath("tests/malformed/ply/vertex_count_2pow31.ply");
    MeshData mesh;
    std::string error;
    EXPECT_FALSE(loadPly(path, mesh, error, unlimited));
    EXPECT_NE(error.find("declares 2147483648 records"), std::string::npos) << error;
}

TEST(MalformedMesh, SymlinkOutOfTheAssetDirectoryIsRefused) {
    test::TempDir dir;
    std::filesystem::create_directories(dir.file("asset"));
    const std::string outside = dir.write("secret.bin", std::string(44, '\0'));
    std::filesystem::create_symlink(outside, dir.file("asset/buffer.bin"));
    const std::string path =
        dir.write("asset/model.gltf",
                  R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":44,"uri":"buffer.bin"}],)"
                  R"("bufferViews":[{"buffer":0,"byteLength":36}],)"
                  R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],)"
                  R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}]})");
    MeshData mesh;
    std::string error;
    EXPECT_FALSE(loadMesh(path, mesh, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("not found"), std::string::npos) << error;

    // The same file inside the directory loads.
    std::filesystem::remove(dir.file("asset/buffer.bin"));
    std::filesystem::copy_file(outside, dir.file("asset/buffer.bin"));
    EXPECT_TRUE(loadMesh(path, mesh, error)) << error;
}

TEST(MalformedMesh, EveryTruncationOfValidFilesIsHandled) {
    // Cut valid files at many lengths: each prefix either loads or is refused, never crashes.
    const std::vector<std::string> sources = {
        test::sourcePath("tests/assets/fixtures/cube.glb"),
        test::sourcePath("tests/assets/fixtures/hierarchy.gltf"),
    };
    test::TempDir dir;
    std::string error;
    MeshData cube;
    ASSERT_TRUE(loadMesh(sources[0], cube, error)) << error;
    ASSERT_TRUE(writePly(dir.file("cube_bin.ply"), cube, error)) << error;
    ASSERT_TRUE(writeObj(dir.file("cube.obj"), cube, error)) << error;
    std::vector<std::string> files = sources;
    files.push_back(dir.file("cube_bin.ply"));
    files.push_back(dir.file("cube.obj"));
    for (const std::string& src : files) {
        std::ifstream in(src, std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        ASSERT_FALSE(bytes.empty()) << src;
        const std::string ext = src.substr(src.find_last_of('.'));
        // Every cut inside the first 256 bytes (headers), then every 7th.
        for (size_t n = 0; n < bytes.size(); n += n < 256 ? 1 : 7) {
            const std::string cut = dir.write("cut" + ext, bytes.substr(0, n));
            MeshData mesh;
            if (!loadMesh(cut, mesh, error)) {
                EXPECT_NE(error.find(cut), std::string::npos) << error;
            }
        }
    }
}

}  // namespace
}  // namespace penumbra::assets
