#include "engine/core/output_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>

namespace penumbra {

namespace fs = std::filesystem;

namespace {

std::string errnoText(int err) { return std::strerror(err); }

// Follows the symbolic links of `path` itself (not of its folders, which the rename goes through
// anyway) so that the file a link points at is replaced, not the link.
bool resolveLinks(const fs::path& path, fs::path& out, std::string& why) {
    fs::path p = path;
    for (int depth = 0; depth < 40; ++depth) {
        struct stat st {};
        if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) {
            out = p;
            return true;
        }
        std::error_code ec;
        const fs::path link = fs::read_symlink(p, ec);
        if (ec) {
            why = fmt::format("cannot read the symbolic link {}: {}", p.string(), ec.message());
            return false;
        }
        p = link.is_absolute() ? link : p.parent_path() / link;
    }
    why = "too many levels of symbolic links";
    return false;
}

std::atomic<unsigned> g_tempCounter{0};

}  // namespace

OutputFiles::~OutputFiles() { discard(); }

OutputFiles::Entry* OutputFiles::find(const std::string& path) {
    for (Entry& e : m_entries)
        if (e.path == path) return &e;
    return nullptr;
}

const OutputFiles::Entry* OutputFiles::find(const std::string& path) const {
    for (const Entry& e : m_entries)
        if (e.path == path) return &e;
    return nullptr;
}

std::string OutputFiles::tempPath(const std::string& path) const {
    const Entry* e = find(path);
    return e ? e->temp : std::string();
}

bool OutputFiles::add(const std::string& path, std::string& error) {
    auto fail = [&](const std::string& why) {
        error = fmt::format("cannot write {}: {}", path, why);
        return false;
    };
    if (path.empty()) {
        error = "cannot write an output with an empty path";
        return false;
    }
    if (m_committed) return fail("internal error: the outputs were already committed");
    const fs::path given(path);
    if (!given.has_filename() || given.filename() == "." || given.filename() == "..")
        return fail("the path names a folder, not a file");

    fs::path target;
    std::string why;
    if (!resolveLinks(given, target, why)) return fail(why);
    if (!target.has_filename() || target.filename() == "." || target.filename() == "..")
        return fail("the path names a folder, not a file");

    // The destination itself: absent, or a regular file that the rename may replace.
    struct stat st {};
    if (::stat(target.c_str(), &st) == 0) {
        if (S_ISDIR(st.st_mode)) return fail("it is a directory");
        if (!S_ISREG(st.st_mode))
            return fail(
                "it exists and is not a regular file (a device, pipe or socket), which an output "
                "may not replace");
    } else if (errno != ENOENT) {
        return fail(errnoText(errno));
    }

    // Missing parent folders are created now (and removed again by discard()).
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    std::vector<fs::path> missing;
    for (fs::path d = dir; !d.empty(); d = d.parent_path()) {
        if (::stat(d.c_str(), &st) == 0) {
            if (!S_ISDIR(st.st_mode)) return fail(fmt::format("{} is not a folder", d.string()));
            break;
        }
        if (errno != ENOENT) return fail(fmt::format("{}: {}", d.string(), errnoText(errno)));
        missing.push_back(d);
        if (d == d.parent_path()) break;
    }
    for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
        if (::mkdir(it->c_str(), 0777) == 0) {
            m_createdDirs.push_back(it->string());
        } else if (errno != EEXIST) {
            return fail(fmt::format("cannot create the folder {}: {}", it->string(), errnoText(errno)));
        }
    }

    // The same file twice (e.g. -o x.png --stats x.png) would silently lose one output.
    std::error_code ec;
    fs::path canonicalDir = fs::canonical(dir, ec);
    if (ec) canonicalDir = fs::absolute(dir, ec).lexically_normal();
    const std::string key = (canonicalDir / target.filename()).string();
    for (const Entry& e : m_entries)
        if (e.key == key) return fail(fmt::format("it is already an output of this command ({})", e.path));

    // Create the temporary file now: this is the real test that the folder can be written.
    std::string base = target.filename().string();
    if (base.size() > 100) base.resize(100);  // keep the temporary name within NAME_MAX
    for (int attempt = 0;; ++attempt) {
        const fs::path temp = dir / fmt::format(".{}.{}-{}.tmp", base, long(::getpid()), g_tempCounter++);
        const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            ::close(fd);
            m_entries.push_back(Entry{path, target.string(), temp.string(), key, false});
            return true;
        }
        if (errno != EEXIST || attempt >= 100) return fail(errnoText(errno));
    }
}

bool OutputFiles::write(const std::string& path, const Writer& writer, std::string& error) {
    Entry* e = find(path);
    if (!e) {
        m_failed = true;
        error = fmt::format("cannot write {}: internal error: it is not an output of this command", path);
        return false;
    }
    std::string why;
    if (!writer(e->temp, why)) {
        m_failed = true;
        error = why.empty() ? fmt::format("cannot write {}", path) : why;
        return false;
    }
    e->written = true;
    return true;
}

bool OutputFiles::writeText(const std::string& path, std::string_view text, std::string& error) {
    return write(
        path,
        [&](const std::string& temp, std::string& why) {
            std::FILE* f = std::fopen(temp.c_str(), "wb");
            if (!f) {
                why = fmt::format("cannot write {}: {}", path, errnoText(errno));
                return false;
            }
            const size_t written = std::fwrite(text.data(), 1, text.size(), f);
            const int writeErrno = errno;
            const bool closed = std::fclose(f) == 0;
            if (written != text.size() || !closed) {
                why = fmt::format("cannot write {}: {}", path,
                                  errnoText(written != text.size() ? writeErrno : errno));
                return false;
            }
            return true;
        },
        error);
}

bool OutputFiles::commit(std::string& error) {
    if (m_committed) return true;
    if (m_failed) {
        error = "an output failed to write; nothing was committed";
        discard();
        return false;
    }
    for (const Entry& e : m_entries) {
        if (!e.written) {
            error = fmt::format("cannot write {}: internal error: the output was never written", e.path);
            discard();
            return false;
        }
        // Data on disk before the rename, so a crash cannot leave a renamed but empty file.
        const int fd = ::open(e.temp.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0 || ::fsync(fd) != 0) {
            error = fmt::format("cannot write {}: {}", e.path, errnoText(errno));
            if (fd >= 0) ::close(fd);
            discard();
            return false;
        }
        ::close(fd);
    }
    for (size_t i = 0; i < m_entries.size(); ++i) {
        if (std::rename(m_entries[i].temp.c_str(), m_entries[i].target.c_str()) != 0) {
            error = fmt::format("cannot write {}: renaming {} into place failed: {}", m_entries[i].path,
                                m_entries[i].temp, errnoText(errno));
            for (size_t j = 0; j < i; ++j) ::unlink(m_entries[j].target.c_str());
            m_entries.erase(m_entries.begin(), m_entries.begin() + std::ptrdiff_t(i));
            discard();
            return false;
        }
    }
    m_entries.clear();
    m_createdDirs.clear();  // they hold the outputs now
    m_committed = true;
    return true;
}

void OutputFiles::discard() {
    for (const Entry& e : m_entries) ::unlink(e.temp.c_str());
    m_entries.clear();
    // Only folders still empty go (rmdir refuses others), the deepest first.
    for (auto it = m_createdDirs.rbegin(); it != m_createdDirs.rend(); ++it) ::rmdir(it->c_str());
    m_createdDirs.clear();
}

}  // namespace penumbra
