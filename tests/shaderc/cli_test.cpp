// penumbra-shaderc as a build step: exit codes, `path:line:` diagnostics (also inside #included
// files), depfiles and write-if-changed outputs.
#include "shaderc_test_util.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using shaderc_test::fixture;
using shaderc_test::readFile;
using shaderc_test::runShaderc;
using shaderc_test::scratchDir;

namespace {

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

TEST(ShadercCli, SyntaxErrorFailsWithFileAndLine) {
    const std::string out = scratchDir("syntax_error");
    const std::string source = fixture("cli/syntax_error.comp");
    const auto r = runShaderc({"--name", "syntax_error", "--out-dir", out, "--comp", source});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, source + ":7: error: ")) << r.output;
    EXPECT_TRUE(contains(r.output, "undeclaredVariable")) << r.output;
    EXPECT_FALSE(fs::exists(fs::path(out) / "syntax_error.cpp"));
    EXPECT_FALSE(fs::exists(fs::path(out) / "syntax_error.h"));
}

TEST(ShadercCli, ErrorInIncludedFileNamesTheIncludedFile) {
    const auto r = runShaderc({"--name", "include_error", "--out-dir", scratchDir("include_error"), "--comp",
                               fixture("cli/include_error.comp")});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    const std::string included = fs::path(fixture("cli/sub/broken.glsl")).lexically_normal().string();
    EXPECT_TRUE(contains(r.output, included + ":4: error: ")) << r.output;
    EXPECT_TRUE(contains(r.output, "notDeclaredAnywhere")) << r.output;
}

TEST(ShadercCli, MissingIncludeIsReportedAtTheDirective) {
    const std::string source = fixture("cli/missing_include.comp");
    const auto r = runShaderc({"--name", "missing_include", "--out-dir", scratchDir("missing_include"),
                               "--comp", source, "-I", fixture("cli/sub")});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, source + ":3: error: ")) << r.output;
    EXPECT_TRUE(contains(r.output, "does_not_exist.glsl")) << r.output;
}

TEST(ShadercCli, SameBindingWithDifferentTypesInTwoStagesIsAnError) {
    const std::string vert = fixture("cli/conflict.vert");
    const std::string frag = fixture("cli/conflict.frag");
    const auto r = runShaderc(
        {"--name", "conflict", "--out-dir", scratchDir("conflict"), "--vert", vert, "--frag", frag});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, "set 0, binding 3")) << r.output;
    EXPECT_TRUE(contains(r.output, vert)) << r.output;
    EXPECT_TRUE(contains(r.output, frag)) << r.output;
}

TEST(ShadercCli, UnsupportedStorageImageFormatIsAnError) {
    const auto r = runShaderc({"--name", "bad_storage_format", "--out-dir", scratchDir("bad_storage_format"),
                               "--comp", fixture("cli/bad_storage_format.comp")});
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, "'unsupported'")) << r.output;
}

TEST(ShadercCli, UsageErrors) {
    EXPECT_NE(runShaderc({"--name", "x", "--out-dir", scratchDir("usage")}).exitCode, 0);
    EXPECT_NE(runShaderc({"--name", "x", "--out-dir", scratchDir("usage"), "--vert", "a.vert"}).exitCode, 0);
    EXPECT_NE(
        runShaderc({"--name", "x", "--out-dir", scratchDir("usage"), "--comp", "a.comp", "--frag", "b.frag"})
            .exitCode,
        0);
    const auto badName = runShaderc({"--name", "not-an-identifier", "--out-dir", scratchDir("usage"),
                                     "--comp", fixture("cli/nested_include.comp")});
    EXPECT_EQ(badName.exitCode, 1) << badName.output;
    const auto missingFile = runShaderc(
        {"--name", "nofile", "--out-dir", scratchDir("usage"), "--comp", fixture("cli/nope.comp")});
    EXPECT_EQ(missingFile.exitCode, 1);
    EXPECT_TRUE(contains(missingFile.output, "nope.comp: error:")) << missingFile.output;
}

TEST(ShadercCli, HelpDescribesTheOptions) {
    const auto r = runShaderc({"--help"});
    EXPECT_EQ(r.exitCode, 0);
    for (const char* option : {"--name", "--out-dir", "--comp", "--vert", "--frag", "-I", "--depfile",
                               "--view-glsl", "--view-header"}) {
        EXPECT_TRUE(contains(r.output, option)) << option << "\n" << r.output;
    }
}

TEST(ShadercCli, DepfileListsEveryIncludedFile) {
    const std::string out = scratchDir("depfile");
    const std::string depfile = out + "/nested_include.d";
    const auto r = runShaderc({"--name", "nested_include", "--out-dir", out, "--comp",
                               fixture("cli/nested_include.comp"), "--depfile", depfile});
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const std::string dep = readFile(depfile);
    const std::string header = (fs::path(out) / "nested_include.h").string();
    const std::string source = (fs::path(out) / "nested_include.cpp").string();
    // Makefile syntax: "<outputs>: <dependencies>".
    EXPECT_EQ(dep.rfind(header + " " + source + ":", 0), 0u) << dep;
    for (const char* file : {"cli/nested_include.comp", "cli/sub/level1.glsl", "cli/sub/level2.glsl"}) {
        EXPECT_TRUE(contains(dep, fs::path(fixture(file)).lexically_normal().string())) << file << "\n"
                                                                                        << dep;
    }
    EXPECT_TRUE(fs::exists(header));
    EXPECT_TRUE(fs::exists(source));
}

TEST(ShadercCli, IncludeDirsAreSearchedAfterTheSourceFolder) {
    // level1.glsl includes "level2.glsl" relative to itself; here the program includes level1.glsl
    // through -I only, from a copy of the source placed elsewhere.
    const std::string dir = scratchDir("include_dirs");
    const std::string source = dir + "/prog.comp";
    {
        std::ofstream f(source);
        f << "#version 450\n#include \"level1.glsl\"\nlayout(local_size_x = 1) in;\n"
             "layout(set = 0, binding = 0) buffer O { float v; } o;\nvoid main() { o.v = level1(); }\n";
    }
    const auto r = runShaderc({"--name", "prog", "--out-dir", dir, "--comp", source, "-I", dir, "-I",
                               fixture("cli/sub"), "--depfile", dir + "/prog.d"});
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(readFile(dir + "/prog.d"), "level2.glsl"));
}

TEST(ShadercCli, OutputsAreRewrittenOnlyWhenTheirContentChanges) {
    const std::string out = scratchDir("unchanged");
    const std::vector<std::string> args = {"--name", "nested_include", "--out-dir",
                                           out,      "--comp",         fixture("cli/nested_include.comp")};
    ASSERT_EQ(runShaderc(args).exitCode, 0);
    const fs::path header = fs::path(out) / "nested_include.h";
    const fs::path source = fs::path(out) / "nested_include.cpp";
    const auto old = fs::file_time_type::clock::now() - std::chrono::hours(1);
    fs::last_write_time(header, old);
    fs::last_write_time(source, old);
    const std::string before = readFile(source.string());
    ASSERT_EQ(runShaderc(args).exitCode, 0);
    EXPECT_EQ(fs::last_write_time(header), old);
    EXPECT_EQ(fs::last_write_time(source), old);
    EXPECT_EQ(readFile(source.string()), before);
}

}  // namespace
