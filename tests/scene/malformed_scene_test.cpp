// Malformed scene files (tests/malformed/scene/*.json): each is refused with one message naming the
// file, the JSON pointer of the element and the reason; the output scene and the asset manager are
// left unchanged. Every file in the folder must have a row here (and every row a file).
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "scene/scene_test_util.h"

namespace penumbra::scene {
namespace {

struct MalformedScene {
    const char* file;
    const char* expected;    // substring of the message (after "<file>: ")
    size_t maxEntities = 0;  // 0: default limits
};

void PrintTo(const MalformedScene& m, std::ostream* os) { *os << m.file; }

const MalformedScene kMalformed[] = {
    // Syntax and document level.
    {"empty.json", "empty file"},
    {"truncated.json", "/entities/0/transform/position/2: JSON syntax error at line 1, column 74"},
    {"trailing_garbage.json", "JSON syntax error at line 1, column 32"},
    {"not_an_object.json", "a scene file must be a JSON object at the top level, got an array"},
    {"depth_bomb.json", "JSON nested deeper than 64 levels at line 1, column 91 (refused before parsing)"},
    {"duplicate_key.json", "/entities/0/name: duplicate key 'name'"},
    {"overflow_1e999.json", "/entities/0/transform/position/1: number '1e999' at line 1"},
    {"float_overflow.json", "/entities/0/transform/position/1: 1e+300 is out of range for a 32-bit float"},
    // Version.
    {"missing_version.json", "/version: missing"},
    {"version_3.json", "/version: scene format version 3 is newer than this build supports (version 2)"},
    {"version_0.json", "/version: unsupported scene format version 0 (expected 1 to 2)"},
    {"version_string.json", "/version: expected an integer, got a string"},
    {"version_fraction.json", "/version: expected an integer, got 1.5"},
    // Strict schema: unknown keys.
    {"unknown_top_key.json", "/entites: unknown key 'entites' in the scene (expected one of: version,"},
    {"unknown_entity_key.json", "/entities/0/meshes: unknown key 'meshes' in an entity"},
    {"unknown_component_field.json", "/entities/0/light/colour: unknown key 'colour' in a point light"},
    {"range_on_directional.json", "/entities/0/light/range: unknown key 'range' in a directional light"},
    {"primitive_foreign_param.json",
     "/entities/0/mesh/primitive/halfExtents: unknown key 'halfExtents' in a sphere primitive"},
    // Wrong types.
    {"entities_not_array.json", "/entities: expected an array of entities, got an object"},
    {"entity_not_object.json", "/entities/1: expected an object, got a string"},
    {"position_wrong_type.json",
     "/entities/0/transform/position: expected an array of 3 numbers, got a string"},
    {"position_two_numbers.json",
     "/entities/0/transform/position: expected an array of 3 numbers, got 2 elements"},
    {"intensity_string.json", "/entities/0/light/intensity: expected a number, got a string"},
    {"width_fraction.json", "/render/width: expected an integer, got 640.5"},
    {"material_wrong_type.json", "/entities/0/mesh/material: expected a material name or a material object"},
    // Unknown names.
    {"unknown_shading.json", "/render/shading: unknown shading model 'phong'"},
    {"unknown_tone_mapper.json", "/render/toneMapper: unknown tone mapper 'filmic'"},
    {"unknown_light_type.json",
     "/entities/3/light/type: unknown light type 'spot2' (expected directional, point or sphere)"},
    {"unknown_material.json", "/entities/0/mesh/material: unknown material 'gold'"},
    {"primitive_unknown_shape.json", "/entities/0/mesh/primitive/shape: unknown primitive shape 'cone'"},
    {"unknown_render_camera.json",
     "/render/camera: no camera named 'side' (named cameras in this scene: main)"},
    // Hierarchy.
    {"unknown_parent.json", "/entities/0/parent: unknown parent 'nobody'"},
    {"parent_cycle.json", "/entities/1/parent: parent cycle: a -> c -> b -> a"},
    {"self_parent.json", "/entities/0/parent: parent cycle: solo -> solo"},
    {"duplicate_names.json", "/entities/2/name: duplicate entity name 'box' (also used by /entities/0)"},
    // Ranges.
    {"width_zero.json", "/render/width: 0 is out of range [1, 16384]"},
    {"negative_intensity.json", "/entities/0/light/intensity: intensity must be >= 0 (got -1)"},
    {"negative_range.json", "/entities/0/light/range: range must be > 0 (got -2)"},
    {"fov_zero.json", "/entities/0/camera/fovYDegrees: 0 is out of range (0, 180)"},
    {"fov_180.json", "/entities/0/camera/fovYDegrees: 180 is out of range (0, 180)"},
    {"near_zero.json", "/entities/0/camera/near: near must be > 0 (got 0)"},
    {"far_less_than_near.json", "/entities/0/camera/far: far (0.5) must be greater than near (1)"},
    {"base_color_out_of_range.json", "/materials/hot/baseColor/0: 1.5 is out of range [0, 1]"},
    {"roughness_negative.json", "/materials/m/roughness: -0.1 is out of range [0, 1]"},
    {"zero_quaternion.json", "/entities/0/transform/rotation: the quaternion [x, y, z, w] has length 0"},
    {"rotation_and_euler.json", "/entities/0/transform/eulerDegrees: give either \"rotation\""},
    {"scale_zero.json", "/entities/0/transform/scale: scale must be > 0 (got 0)"},
    {"scale_component_negative.json", "/entities/0/transform/scale/1: scale must be > 0 (got -1)"},
    {"spin_zero_axis.json", "/entities/0/spin/axis: the axis has length 0"},
    {"primitive_negative_radius.json", "/entities/0/mesh/primitive/radius: radius must be > 0 (got -1)"},
    {"primitive_few_segments.json", "/entities/0/mesh/primitive/segments: 2 is out of range [3, 1024]"},
    {"primitive_fat_torus.json",
     "/entities/0/mesh/primitive: torus: minorRadius (1) must be smaller than majorRadius (1)"},
    {"mesh_file_and_primitive.json", "/entities/0/mesh: give either \"file\" or \"primitive\", not both"},
    // Limits.
    {"too_many_entities.json", "/entities: 10 entities exceed the limit of 4", 4},
    // Referenced files.
    {"missing_mesh_file.json",
     "/entities/0/mesh/file: mesh file 'no_such_mesh.ply' not found (resolved to '"},
    {"missing_npm_mesh.json", "data/meshes are fetched by tools/fetch_meshes.sh"},
    {"malformed_mesh_file.json",
     "/entities/0/mesh/file: " PENUMBRA_SOURCE_DIR "/tests/malformed/ply/nan_vertex.ply"},
    {"mesh_is_directory.json", "/entities/0/mesh/file: mesh file '../ply' is a directory, not a file"},
    {"missing_texture.json", "/materials/m/baseColorTexture: texture file 'no_such_texture.png' not found"},
    {"missing_gltf_file.json", "/entities/0/gltf: glTF file 'no_such_scene.gltf' not found"},
    {"malformed_gltf_file.json",
     "/entities/0/gltf: " PENUMBRA_SOURCE_DIR "/tests/malformed/gltf/node_cycle.gltf"},
    // The sdf component (version 2).
    {"sdf_in_version_1.json",
     "/entities/0/sdf: the sdf component needs scene format version 2 (this file is version 1)"},
    {"sdf_no_source.json", "/entities/0/sdf: an sdf component needs \"shape\" (one analytic shape), \"csg\""},
    {"sdf_two_sources.json",
     "/entities/0/sdf/psdf: give one of \"shape\", \"csg\", \"psdf\" or \"mesh\" (this "
     "component already has \"shape\")"},
    {"sdf_unknown_key.json", "/entities/0/sdf/steps: unknown key 'steps' in an sdf component"},
    {"sdf_unknown_shape.json", "/entities/0/sdf/shape/shape: unknown shape 'pyramid' (expected sphere, box,"},
    {"sdf_negative_radius.json", "/entities/0/sdf/shape: sphere: radius must be > 0 (got -1)"},
    {"sdf_radius_string.json", "/entities/0/sdf/shape/radius: expected a number, got a string"},
    {"sdf_csg_one_child.json",
     "/entities/0/sdf/csg/children: a union node needs at least two children (got 1)"},
    {"sdf_unknown_op.json",
     "/entities/0/sdf/csg/op: unknown operation 'xor' (expected union, subtract, intersect or "
     "repeat)"},
    {"sdf_op_as_shape.json", "/entities/0/sdf/shape: expected a shape node with \"shape\""},
    {"sdf_repeat_overlap.json",
     "/entities/0/sdf/csg: the repeated shape's bounds on x ([-1, 1]) must lie strictly "
     "inside its cell (-0.75, 0.75)"},
    {"sdf_repeat_count_zero.json", "/entities/0/sdf/csg/count/0: 0 is out of range [1, 1024]"},
    {"sdf_nonuniform_shape_scale.json",
     "/entities/0/sdf/csg/children/1/transform/scale: a shape's scale is one number (uniform), got an array"},
    {"sdf_nested_bad_child.json", "/entities/0/sdf/csg/children/1: box: halfExtents must be > 0 (got -1)"},
    {"sdf_smooth_radius_zero.json", "/entities/0/sdf/csg/smoothRadius: smoothRadius must be > 0 (got 0)"},
    {"sdf_too_deep.json",
     "/children/1/children/1/children/0: the program needs a distance stack deeper than 16 (every operand"},
    {"sdf_missing_psdf.json", "/entities/0/sdf/psdf: .psdf file 'no_such.psdf' not found (resolved to '"},
    {"sdf_bad_psdf.json",
     "/entities/0/sdf/psdf: " PENUMBRA_SOURCE_DIR "/tests/malformed/psdf/bad_payload_crc.psdf"},
    {"sdf_missing_mesh.json", "/entities/0/sdf/mesh: mesh file 'no_such_mesh.ply' not found (resolved to '"},
    {"sdf_resolution_without_mesh.json",
     "/entities/0/sdf/resolution: \"resolution\" applies to \"mesh\" only (the bake resolution)"},
    {"sdf_resolution_too_high.json", "/entities/0/sdf/resolution: 4096 is out of range [8, 1024]"},
    {"sdf_max_steps_zero.json", "/entities/0/sdf/maxSteps: 0 is out of range [1, 10000]"},
};

std::string malformedDir() { return test::sourcePath("tests/malformed/scene/"); }

class MalformedSceneTest : public testing::TestWithParam<MalformedScene> {};

TEST_P(MalformedSceneTest, RefusedWithClearMessageAndNothingChanged) {
    const MalformedScene& row = GetParam();
    const std::string path = malformedDir() + row.file;
    ASSERT_TRUE(std::filesystem::exists(path)) << path;
    SceneLoadLimits limits;
    if (row.maxEntities) limits.maxEntities = row.maxEntities;

    assets::AssetManager assets;
    Scene out;
    out.sourcePath = "untouched";
    out.settings.width = 17;
    const ecs::Entity marker = out.world.create();
    out.world.add<ecs::Name>(marker, std::string("marker"));

    std::string error;
    EXPECT_FALSE(loadScene(path, assets, out, error, limits));
    // One message: "<file>: <pointer>: <reason>" (or "<file>: <reason>" for whole-document errors).
    EXPECT_EQ(error.rfind(path + ": ", 0), 0u) << "the message starts with the file name: " << error;
    EXPECT_NE(error.find(row.expected), std::string::npos)
        << "expected '" << row.expected << "' in: " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << "one line: " << error;
    EXPECT_EQ(assets.count(), 0u) << "every asset reference taken during the attempt is released";
    EXPECT_EQ(out.sourcePath, "untouched");
    EXPECT_EQ(out.settings.width, 17u);
    EXPECT_EQ(out.world.aliveCount(), 1u);
    EXPECT_TRUE(out.world.alive(marker));
    EXPECT_TRUE(out.assetRefs.empty());
}

INSTANTIATE_TEST_SUITE_P(Files, MalformedSceneTest, testing::ValuesIn(kMalformed),
                         [](const testing::TestParamInfo<MalformedScene>& info) {
                             std::string name = info.param.file;
                             name = name.substr(0, name.find('.'));
                             return name;
                         });

TEST(MalformedScene, EveryFileHasARowAndEveryRowAFile) {
    std::set<std::string> rows;
    for (const MalformedScene& row : kMalformed) {
        EXPECT_TRUE(rows.insert(row.file).second) << "duplicate row " << row.file;
    }
    std::set<std::string> files;
    for (const auto& entry : std::filesystem::directory_iterator(malformedDir())) {
        if (entry.path().extension() == ".json") files.insert(entry.path().filename().string());
    }
    EXPECT_EQ(rows, files);
    EXPECT_GE(files.size(), 25u);
}

// The same text parsed from memory fails the same way, with the name given by the caller.
TEST(MalformedScene, ParseFromMemoryNamesTheCallersName) {
    assets::AssetManager assets;
    Scene out;
    std::string error;
    EXPECT_FALSE(parseJsonScene(R"({"version": 1, "entities": [{"light": {"type": "spot2"}}]})",
                                "inline scene", ".", assets, out, error));
    EXPECT_EQ(
        error,
        "inline scene: /entities/0/light/type: unknown light type 'spot2' (expected directional, point or "
        "sphere)");
    EXPECT_FALSE(parseJsonScene("", "nothing", ".", assets, out, error));
    EXPECT_EQ(error, "nothing: empty file (a scene file is a JSON object)");
}

// Keys containing '/' and '~' are escaped in pointers (RFC 6901).
TEST(MalformedScene, PointerTokensAreEscaped) {
    assets::AssetManager assets;
    Scene out;
    std::string error;
    EXPECT_FALSE(parseJsonScene(R"({"version": 1, "materials": {"a/b~c": {"metallic": 2}}})", "s.json", ".",
                                assets, out, error));
    EXPECT_NE(error.find("s.json: /materials/a~1b~0c/metallic: 2 is out of range [0, 1]"), std::string::npos)
        << error;
}

// A depth just under the cap parses (the cap refuses, it does not truncate).
TEST(MalformedScene, DepthCapIsExact) {
    assets::AssetManager assets;
    Scene out;
    std::string error;
    SceneLoadLimits limits;
    limits.maxJsonDepth = 8;
    // 8 levels pass the depth scan (and then fail the schema: an entity must be an object); 9 are
    // refused before parsing.
    const std::string eight = R"({"version": 1, "entities": [[[[[[[]]]]]]]})";
    EXPECT_FALSE(parseJsonScene(eight, "d.json", ".", assets, out, error, limits));
    EXPECT_EQ(error.find("nested deeper"), std::string::npos) << error;
    const std::string nine = R"({"version": 1, "entities": [[[[[[[[]]]]]]]]})";
    EXPECT_FALSE(parseJsonScene(nine, "d.json", ".", assets, out, error, limits));
    EXPECT_NE(error.find("d.json: JSON nested deeper than 8 levels"), std::string::npos) << error;
    // Brackets inside strings do not count.
    const std::string inString = R"({"version": 1, "description": "[[[[[[[[[[[[[[[[\"[[[["})";
    EXPECT_TRUE(parseJsonScene(inString, "d.json", ".", assets, out, error, limits)) << error;
}

}  // namespace
}  // namespace penumbra::scene
