// The shaderc core driven in-process: names, depfile syntax, diagnostics collection.
#include "shaderc.h"
#include "shaderc_test_util.h"

#include <gtest/gtest.h>

#include <fstream>

namespace {

using penumbra::shaderc::compileProgram;
using penumbra::shaderc::ProgramOutput;
using penumbra::shaderc::ProgramRequest;

TEST(ShadercCore, ProgramNamesMustBeUsableAsNamespaces) {
    EXPECT_TRUE(penumbra::shaderc::isValidProgramName("sdf_trace"));
    EXPECT_TRUE(penumbra::shaderc::isValidProgramName("Pass2"));
    EXPECT_FALSE(penumbra::shaderc::isValidProgramName(""));
    EXPECT_FALSE(penumbra::shaderc::isValidProgramName("2pass"));
    EXPECT_FALSE(penumbra::shaderc::isValidProgramName("sdf-trace"));
    EXPECT_FALSE(penumbra::shaderc::isValidProgramName("default"));
}

TEST(ShadercCore, DepfileEscapesSpecialCharacters) {
    const std::string text =
        penumbra::shaderc::generateDepfile({"/out/a.h", "/out/a.cpp"}, {"/src dir/a.comp", "/src/$x#.glsl"});
    EXPECT_EQ(text, "/out/a.h /out/a.cpp: \\\n  /src\\ dir/a.comp \\\n  /src/$$x\\#.glsl\n");
}

TEST(ShadercCore, CompileProgramCollectsDiagnosticsOfBothStages) {
    ProgramRequest request;
    request.name = "conflict";
    request.stages = {{rhi::ShaderStage::Vertex, shaderc_test::fixture("cli/conflict.vert")},
                      {rhi::ShaderStage::Fragment, shaderc_test::fixture("cli/conflict.frag")}};
    ProgramOutput out;
    std::vector<std::string> diagnostics;
    EXPECT_FALSE(compileProgram(request, out, diagnostics));
    ASSERT_EQ(diagnostics.size(), 1u);
    EXPECT_NE(diagnostics[0].find("set 0, binding 3"), std::string::npos) << diagnostics[0];
}

TEST(ShadercCore, CompileProgramRecordsDependencies) {
    ProgramRequest request;
    request.name = "nested_include";
    request.stages = {{rhi::ShaderStage::Compute, shaderc_test::fixture("cli/nested_include.comp")}};
    ProgramOutput out;
    std::vector<std::string> diagnostics;
    ASSERT_TRUE(compileProgram(request, out, diagnostics));
    EXPECT_TRUE(diagnostics.empty());
    EXPECT_EQ(out.dependencies.size(), 3u);
    ASSERT_EQ(out.stages.size(), 1u);
    EXPECT_EQ(out.stages[0].workgroupSize, (std::array<uint32_t, 3>{2, 1, 1}));
    const std::string header = penumbra::shaderc::generateHeader(out);
    EXPECT_NE(header.find("namespace penumbra::shaders::nested_include {"), std::string::npos) << header;
    EXPECT_NE(header.find("const rhi::ShaderDesc& compute();"), std::string::npos) << header;
}

TEST(ShadercCore, RejectsPushConstantsOverTheLimit) {
    const std::string dir = shaderc_test::scratchDir("big_push");
    const std::string path = dir + "/big.comp";
    {
        std::ofstream f(path);
        f << "#version 450\nlayout(local_size_x = 1) in;\n"
             "layout(push_constant) uniform P { mat4 a; mat4 b; vec4 c; } pc;\n"
             "layout(set = 0, binding = 0) buffer O { vec4 v; } o;\nvoid main() { o.v = pc.a[0] + pc.b[0] + "
             "pc.c; }\n";
    }
    ProgramRequest request;
    request.name = "big";
    request.stages = {{rhi::ShaderStage::Compute, path}};
    ProgramOutput out;
    std::vector<std::string> diagnostics;
    EXPECT_FALSE(compileProgram(request, out, diagnostics));
    ASSERT_FALSE(diagnostics.empty());
    EXPECT_NE(diagnostics[0].find("144 bytes"), std::string::npos) << diagnostics[0];
}

}  // namespace
