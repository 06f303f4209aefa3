// penumbra-shaderc's parameter-struct, variant and per-view checks as a build step: blocks that
// C++ cannot express, unused variant defines and foreign View blocks fail with `path:line:`
// diagnostics, and the generated static_asserts reject a C++ layout that differs from the GLSL
// one (a try-compile of the generated header with the project's compiler).
#include "shaderc_test_util.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <regex>

namespace fs = std::filesystem;
using shaderc_test::fixture;
using shaderc_test::readFile;
using shaderc_test::runShaderc;
using shaderc_test::scratchDir;
using shaderc_test::writeFile;

namespace {

const std::string kViewGlsl = std::string(SHADERC_RENDERER_SHADERS) + "/view.glsl";

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

shaderc_test::RunResult compileComp(const std::string& name, const std::string& source,
                                    bool withView = true) {
    const std::string dir = scratchDir(name);
    const std::string path = dir + "/" + name + ".comp";
    writeFile(path, source);
    std::vector<std::string> args = {"--name", name, "--out-dir", dir, "--comp", path};
    if (withView) args.insert(args.end(), {"--view-glsl", kViewGlsl});
    return runShaderc(args);
}

// Criterion: a std140 float[4] (16-byte stride) fails the tool at the member's line, saying why.
TEST(ShadercInterfaceCli, InexpressibleBlockFailsWithFileAndLine) {
    const std::string source = fixture("cli/inexpressible.comp");
    const std::string out = scratchDir("inexpressible");
    const auto r = runShaderc({"--name", "inexpressible", "--out-dir", out, "--comp", source});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, source + ":6: error: ")) << r.output;
    EXPECT_TRUE(contains(r.output, "cannot be expressed as a C++ struct")) << r.output;
    EXPECT_TRUE(contains(r.output, "16-byte array stride")) << r.output;
    EXPECT_FALSE(fs::exists(out + "/inexpressible.h"));
}

// Criterion: member types without a C++ parameter type are errors at their line.
TEST(ShadercInterfaceCli, UnsupportedMemberTypesAreErrorsAtTheirLine) {
    const std::string prefix =
        "#version 450\nlayout(local_size_x = 1) in;\nlayout(set = 0, binding = 0, std430) buffer B {\n    "
        "vec4 a;\n";
    const std::string suffix = "} b;\nvoid main() { b.a = vec4(1.0); }\n";
    struct Case {
        const char* name;
        const char* member;
        const char* message;
    };
    for (const Case& c : {Case{"double_member", "    double d;\n", "double has no C++ parameter type"},
                          Case{"row_major_member", "    layout(row_major) mat4 m;\n", "row_major"},
                          Case{"nested_array", "    vec4 grid[2][2];\n", "arrays of arrays"}}) {
        SCOPED_TRACE(c.name);
        const auto r = compileComp(c.name, prefix + c.member + suffix);
        EXPECT_EQ(r.exitCode, 1) << r.output;
        EXPECT_TRUE(contains(r.output, std::string(c.name) + ".comp:5: error: ")) << r.output;
        EXPECT_TRUE(contains(r.output, c.message)) << r.output;
    }
}

// Criterion: a declared variant define that no stage uses is an error at the pragma's line; the
// used one is not reported.
TEST(ShadercInterfaceCli, UnusedVariantDefineIsAnError) {
    const std::string source = fixture("cli/unused_variant.comp");
    const auto r =
        runShaderc({"--name", "unused_variant", "--out-dir", scratchDir("unused_variant"), "--comp", source});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, source + ":2: error: variant NeverUsed (NEVER_USED)")) << r.output;
    EXPECT_TRUE(contains(r.output, "uses NEVER_USED")) << r.output;
    EXPECT_FALSE(contains(r.output, "(USED)")) << r.output;
}

// Criterion: malformed variant declarations are errors at their line.
TEST(ShadercInterfaceCli, MalformedVariantPragmasAreErrors) {
    const std::string body =
        "layout(local_size_x = 1) in;\nlayout(set = 0, binding = 0) buffer O { float v; } o;\n"
        "void main() { o.v = 1.0; }\n";
    const auto reserved =
        compileComp("variant_reserved", "#version 450\n#pragma penumbra_variants GL_THING\n" + body);
    EXPECT_EQ(reserved.exitCode, 1) << reserved.output;
    EXPECT_TRUE(contains(reserved.output, "variant_reserved.comp:2: error: 'GL_THING'")) << reserved.output;
    const auto empty = compileComp("variant_empty", "#version 450\n#pragma penumbra_variants\n" + body);
    EXPECT_EQ(empty.exitCode, 1) << empty.output;
    EXPECT_TRUE(contains(empty.output, "variant_empty.comp:2: error: ")) << empty.output;
    const auto clash =
        compileComp("variant_clash", "#version 450\n#pragma penumbra_variants A_B A+B\n" + body);
    EXPECT_EQ(clash.exitCode, 1) << clash.output;
    EXPECT_TRUE(contains(clash.output, "are both called AB")) << clash.output;
}

// Criterion: a block named View with another layout or slot than view.glsl's fails the tool; without
// --view-glsl it is an ordinary block.
TEST(ShadercInterfaceCli, ViewBlocksMustMatchTheSharedLayout) {
    const std::string source = fixture("cli/bad_view.comp");
    const auto r = runShaderc({"--name", "bad_view", "--out-dir", scratchDir("bad_view"), "--comp", source,
                               "--view-glsl", kViewGlsl});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, source +
                                       ":4: error: uniform block 'View' does not match the shared per-view "
                                       "block"))
        << r.output;
    EXPECT_TRUE(contains(r.output, "view.glsl:")) << r.output;

    const std::string plainDir = scratchDir("bad_view_plain");
    const auto plain = runShaderc({"--name", "bad_view", "--out-dir", plainDir, "--comp", source});
    EXPECT_EQ(plain.exitCode, 0) << plain.output;
    EXPECT_TRUE(contains(readFile(plainDir + "/bad_view.h"), "struct View {"));

    const auto wrongSlot =
        compileComp("view_wrong_slot",
                    "#version 450\nlayout(local_size_x = 1) in;\n"
                    "layout(set = 1, binding = 0) uniform View { vec4 a; } v;\n"
                    "layout(set = 0, binding = 1) buffer O { vec4 v; } o;\nvoid main() { o.v = v.a; }\n");
    EXPECT_EQ(wrongSlot.exitCode, 1) << wrongSlot.output;
    EXPECT_TRUE(contains(wrongSlot.output, "view_wrong_slot.comp:3: error: uniform block 'View' is at set 1"))
        << wrongSlot.output;

    // Including view.glsl is the way to get it: the header then uses the shared struct.
    const std::string goodDir = scratchDir("view_included");
    const std::string good = goodDir + "/good.comp";
    writeFile(good,
              "#version 450\n#include \"view.glsl\"\nlayout(local_size_x = 1) in;\n"
              "layout(set = 0, binding = 1) buffer O { vec4 v; } o;\nvoid main() { o.v = view.viewport; }\n");
    const auto ok = runShaderc({"--name", "good", "--out-dir", goodDir, "--comp", good, "-I",
                                SHADERC_RENDERER_SHADERS, "--view-glsl", kViewGlsl});
    ASSERT_EQ(ok.exitCode, 0) << ok.output;
    const std::string header = readFile(goodDir + "/good.h");
    EXPECT_TRUE(contains(header, "#include <shaders/view.h>")) << header;
    EXPECT_TRUE(contains(header, "using ::penumbra::shaders::View;")) << header;
    EXPECT_FALSE(contains(header, "struct View")) << header;
}

// Criterion: one GLSL type name has one layout per program (a longer declaration of the same
// members is accepted); different members are an error naming both declarations.
TEST(ShadercInterfaceCli, OneLayoutPerTypeNameAcrossStages) {
    const std::string dir = scratchDir("stage_layouts");
    writeFile(dir + "/a.vert",
              "#version 450\nlayout(set = 0, binding = 0) uniform Camera {\n    mat4 viewProj;\n} camera;\n"
              "void main() { gl_Position = camera.viewProj[0]; }\n");
    writeFile(
        dir + "/a.frag",
        "#version 450\nlayout(location = 0) out vec4 c;\nlayout(set = 0, binding = 0) uniform Camera {\n"
        "    vec4 tint;\n} camera;\nvoid main() { c = camera.tint; }\n");
    const auto r =
        runShaderc({"--name", "a", "--out-dir", dir, "--vert", dir + "/a.vert", "--frag", dir + "/a.frag"});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, dir + "/a.frag:3: error: 'Camera' has a different layout here than at " +
                                       dir + "/a.vert:2"))
        << r.output;
}

// Criterion: --view-header writes view.h with the View struct of view.glsl; it needs --view-glsl.
TEST(ShadercInterfaceCli, ViewHeader) {
    const std::string dir = scratchDir("view_header");
    const auto r =
        runShaderc({"--view-header", "--view-glsl", kViewGlsl, "--out-dir", dir, "--depfile", dir + "/v.d"});
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const std::string header = readFile(dir + "/view.h");
    EXPECT_TRUE(contains(header, "namespace penumbra::shaders {")) << header;
    EXPECT_TRUE(contains(header, "struct View {")) << header;
    EXPECT_TRUE(contains(header, "static_assert(offsetof(View, frameIndex) == ")) << header;
    EXPECT_TRUE(contains(readFile(dir + "/v.d"), "view.glsl"));
    EXPECT_EQ(runShaderc({"--view-header", "--out-dir", dir}).exitCode, 2);
    EXPECT_NE(
        runShaderc({"--view-header", "--view-glsl", kViewGlsl, "--out-dir", dir, "--name", "x"}).exitCode, 0);
}

std::string compileHeader(const std::string& dir, const std::string& include) {
    writeFile(dir + "/tu.cpp", "#include <shaders/" + include + ">\nint main() { return 0; }\n");
    const std::string command = std::string("'") + SHADERC_CXX_COMPILER +
                                "' -std=c++20 -fsyntax-only -Wall -Wextra -Wpedantic -Werror " +
                                SHADERC_CXX_INCLUDES + " -I'" + dir + "' '" + dir + "/tu.cpp'";
    const auto r = shaderc_test::runCommand(command);
    return r.exitCode == 0 ? "" : r.output.empty() ? "failed" : r.output;
}

// Criterion: the generated header has a static_assert for the size and for every member offset,
// compiles as it is, and stops compiling when its C++ layout is changed (padding or a type).
TEST(ShadercInterfaceCli, StaticAssertsRejectALayoutMismatch) {
    const std::string dir = scratchDir("try_compile");
    const std::string out = dir + "/shaders";
    const std::string programs = SHADERC_PROGRAMS;
    ASSERT_EQ(runShaderc({"--name", "params", "--out-dir", out, "--comp", programs + "/params.comp", "-I",
                          SHADERC_RENDERER_SHADERS, "--view-glsl", kViewGlsl})
                  .exitCode,
              0);
    ASSERT_EQ(runShaderc({"--view-header", "--view-glsl", kViewGlsl, "--out-dir", out}).exitCode, 0);
    const std::string header = readFile(out + "/params.h");
    for (const char* member : {"scale", "axis", "extent", "count", "mask", "cell", "dims", "enabled",
                               "transform", "rotation", "basis", "colors", "inners", "single", "tail"}) {
        EXPECT_TRUE(contains(header, std::string("static_assert(offsetof(Params, ") + member + ") == "))
            << member;
    }
    EXPECT_TRUE(contains(header, "static_assert(sizeof(Params) == 372,")) << header;
    ASSERT_EQ(compileHeader(dir, "params.h"), "");

    // Padding removed: axis moves from 16 to 12.
    const std::string padded = "    float scale{};  // float, offset 0\n    unsigned char _pad0[12]{};";
    ASSERT_TRUE(contains(header, padded)) << header;
    std::string tampered = header;
    tampered.replace(tampered.find(padded), padded.size(),
                     "    float scale{};  // float, offset 0\n    unsigned char _pad0[8]{};");
    writeFile(out + "/params.h", tampered);
    const std::string padError = compileHeader(dir, "params.h");
    EXPECT_TRUE(contains(padError, "Params::axis: the C++ offset differs from the GLSL layout")) << padError;

    // A wider type: the size no longer matches.
    tampered = header;
    const std::string tail = "    float tail{};";
    ASSERT_TRUE(contains(header, tail));
    tampered.replace(tampered.find(tail), tail.size(), "    double tail{};");
    writeFile(out + "/params.h", tampered);
    const std::string sizeError = compileHeader(dir, "params.h");
    EXPECT_TRUE(contains(sizeError, "Params: the C++ size differs from the GLSL layout")) << sizeError;

    // The shared view header compiles on its own, and breaks the same way.
    ASSERT_EQ(compileHeader(dir, "view.h"), "");
    const std::string view = readFile(out + "/view.h");
    const std::string time = "    float time{};";
    ASSERT_TRUE(contains(view, time)) << view;
    std::string brokenView = view;
    brokenView.replace(brokenView.find(time), time.size(), "    float time{};\n    float inserted{};");
    writeFile(out + "/view.h", brokenView);
    const std::string viewError = compileHeader(dir, "view.h");
    EXPECT_TRUE(contains(viewError, "View::deltaTime: the C++ offset differs")) << viewError;
}

}  // namespace
