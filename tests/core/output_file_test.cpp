// OutputFiles (engine/core/output_file.h): validation before the work, temporary files in the
// destination folder, all-or-nothing commit, nothing left behind on failure.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/output_file.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;

class OutputFilesTest : public ::testing::Test {
protected:
    void SetUp() override {
        m_dir = fs::temp_directory_path() / ("penumbra_output_files_" + std::to_string(::getpid()) + "_" +
                                             ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(m_dir);
        fs::create_directories(m_dir);
    }
    void TearDown() override { fs::remove_all(m_dir); }

    std::string path(const std::string& name) const { return (m_dir / name).string(); }
    // Every entry under the test folder, relative, sorted.
    std::vector<std::string> entries() const {
        std::vector<std::string> out;
        for (const auto& e : fs::recursive_directory_iterator(m_dir))
            out.push_back(fs::relative(e.path(), m_dir).string());
        std::sort(out.begin(), out.end());
        return out;
    }
    static std::string read(const std::string& p) {
        std::ifstream f(p, std::ios::binary);
        std::stringstream ss;
        ss << f.rdbuf();
        return ss.str();
    }

    fs::path m_dir;
};

// Criterion: outputs appear under their names only at commit(), with the written content, and no
// temporary file remains.
TEST_F(OutputFilesTest, CommitRenamesEveryOutputIntoPlace) {
    OutputFiles out;
    std::string error;
    ASSERT_TRUE(out.add(path("a.txt"), error)) << error;
    ASSERT_TRUE(out.add(path("sub/dir/b.txt"), error)) << error;
    EXPECT_FALSE(fs::exists(path("a.txt")));
    ASSERT_TRUE(out.writeText(path("a.txt"), "alpha", error)) << error;
    ASSERT_TRUE(out.write(
        path("sub/dir/b.txt"),
        [](const std::string& temp, std::string&) {
            std::ofstream(temp) << "beta";
            return true;
        },
        error))
        << error;
    EXPECT_FALSE(fs::exists(path("a.txt")));
    ASSERT_TRUE(out.commit(error)) << error;
    EXPECT_EQ(read(path("a.txt")), "alpha");
    EXPECT_EQ(read(path("sub/dir/b.txt")), "beta");
    EXPECT_EQ(entries(), (std::vector<std::string>{"a.txt", "sub", "sub/dir", "sub/dir/b.txt"}));
}

// Criterion: without commit() the destructor removes the temporaries and the folders add()
// created, and an existing file keeps its old content (never replaced by a partial one).
TEST_F(OutputFilesTest, FailureLeavesNothingBehindAndKeepsExistingFiles) {
    std::ofstream(path("old.txt")) << "old content";
    {
        OutputFiles out;
        std::string error;
        ASSERT_TRUE(out.add(path("old.txt"), error)) << error;
        ASSERT_TRUE(out.add(path("new/deeper/n.txt"), error)) << error;
        ASSERT_TRUE(out.writeText(path("old.txt"), "partial", error)) << error;
        EXPECT_FALSE(out.write(
            path("new/deeper/n.txt"),
            [](const std::string&, std::string& why) {
                why = "simulated failure";
                return false;
            },
            error));
        EXPECT_EQ(error, "simulated failure");
        EXPECT_FALSE(out.commit(error));  // a failed write refuses the commit
    }
    EXPECT_EQ(entries(), (std::vector<std::string>{"old.txt"}));
    EXPECT_EQ(read(path("old.txt")), "old content");
}

// Criterion: an output that was never written is not committed as an empty file.
TEST_F(OutputFilesTest, CommitRefusesAnUnwrittenOutput) {
    OutputFiles out;
    std::string error;
    ASSERT_TRUE(out.add(path("a.txt"), error)) << error;
    ASSERT_TRUE(out.add(path("b.txt"), error)) << error;
    ASSERT_TRUE(out.writeText(path("a.txt"), "alpha", error)) << error;
    EXPECT_FALSE(out.commit(error));
    EXPECT_NE(error.find("b.txt"), std::string::npos) << error;
    EXPECT_TRUE(entries().empty());
}

// Criterion: unwritable destinations fail in add() (before any work) with the system's reason.
TEST_F(OutputFilesTest, UnwritablePathsFailInAddWithTheReason) {
    OutputFiles out;
    std::string error;
    EXPECT_FALSE(out.add("/proc/penumbra_output_test.png", error));
    EXPECT_EQ(error.rfind("cannot write /proc/penumbra_output_test.png: ", 0), 0u) << error;

    EXPECT_FALSE(out.add("/proc/penumbra_no_such_folder/x.png", error));
    EXPECT_NE(error.find("cannot create the folder /proc/penumbra_no_such_folder: No such file or directory"),
              std::string::npos)
        << error;

    std::ofstream(path("file")) << "x";
    EXPECT_FALSE(out.add(path("file/x.png"), error));
    EXPECT_NE(error.find("file/x.png: Not a directory"), std::string::npos) << error;
    EXPECT_FALSE(out.add(path("file/sub/x.png"), error));
    EXPECT_NE(error.find("Not a directory"), std::string::npos) << error;

    fs::create_directories(path("adir"));
    EXPECT_FALSE(out.add(path("adir"), error));
    EXPECT_NE(error.find("it is a directory"), std::string::npos) << error;
    EXPECT_FALSE(out.add(path("adir/"), error));
    EXPECT_NE(error.find("names a folder"), std::string::npos) << error;

    EXPECT_FALSE(out.add("/dev/null", error));  // renaming over it would replace the device
    EXPECT_NE(error.find("not a regular file"), std::string::npos) << error;
    EXPECT_TRUE(fs::is_character_file("/dev/null"));

    EXPECT_FALSE(out.add("", error));
}

// Criterion: the same file named twice (also through another spelling) is refused.
TEST_F(OutputFilesTest, TheSameFileTwiceIsRefused) {
    OutputFiles out;
    std::string error;
    ASSERT_TRUE(out.add(path("x.png"), error)) << error;
    EXPECT_FALSE(out.add((m_dir / "." / "x.png").string(), error));
    EXPECT_NE(error.find("already an output"), std::string::npos) << error;
}

// Criterion: a destination that is a symbolic link is written through the link: the target gets
// the content and the link stays a link.
TEST_F(OutputFilesTest, SymbolicLinksAreWrittenThrough) {
    std::ofstream(path("target.txt")) << "old";
    fs::create_symlink("target.txt", path("link.txt"));
    OutputFiles out;
    std::string error;
    ASSERT_TRUE(out.add(path("link.txt"), error)) << error;
    ASSERT_TRUE(out.writeText(path("link.txt"), "new", error)) << error;
    ASSERT_TRUE(out.commit(error)) << error;
    EXPECT_TRUE(fs::is_symlink(path("link.txt")));
    EXPECT_EQ(read(path("target.txt")), "new");
}

// Criterion: committed files get the usual permissions (0666 minus the umask), not the 0600 of a
// private temporary file.
TEST_F(OutputFilesTest, CommittedFilesHonourTheUmask) {
    const mode_t old = ::umask(022);
    OutputFiles out;
    std::string error;
    ASSERT_TRUE(out.add(path("a.txt"), error)) << error;
    ASSERT_TRUE(out.writeText(path("a.txt"), "alpha", error)) << error;
    ASSERT_TRUE(out.commit(error)) << error;
    ::umask(old);
    struct stat st {};
    ASSERT_EQ(::stat(path("a.txt").c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0644u);
}

// Criterion: temporaries live next to their destination (same file system: atomic rename) and are
// hidden dot files.
TEST_F(OutputFilesTest, TemporariesAreHiddenFilesInTheDestinationFolder) {
    OutputFiles out;
    std::string error;
    ASSERT_TRUE(out.add(path("d/x.png"), error)) << error;
    const fs::path temp(out.tempPath(path("d/x.png")));
    EXPECT_EQ(temp.parent_path(), m_dir / "d");
    EXPECT_EQ(temp.filename().string().rfind(".x.png.", 0), 0u) << temp;
    EXPECT_TRUE(fs::exists(temp));
    EXPECT_EQ(out.tempPath(path("other.png")), "");
}

}  // namespace
}  // namespace penumbra
