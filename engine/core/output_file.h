// All-or-nothing output files for commands that write several files (an image plus a statistics
// file, a .psdf plus a report, ...). The rule every `penumbra` command follows:
//
//   1. before any work, every output path is validated with add(): missing parent folders are
//      created, and a temporary file is created next to the destination (so a path that cannot be
//      written fails at once, with the system's reason, e.g. "Permission denied");
//   2. the work writes each output to its temporary file (write(), writeText());
//   3. commit() renames every temporary into place once the whole command has succeeded.
//
// Without commit() (a failure, an early return, an exception) the destructor removes every
// temporary file and every folder add() created, so a failed command leaves no output behind and
// never replaces an existing file with a partial one.
//
//   OutputFiles outputs;
//   if (!outputs.add(imagePath, error) || !outputs.add(statsPath, error)) return fail(error);
//   ... render ...
//   outputs.write(imagePath, [&](const std::string& tmp, std::string& e) { return writePng(tmp, img, &e); },
//   error); outputs.writeText(statsPath, json, error); if (!outputs.commit(error)) return fail(error);
//
// Temporary files are named ".<name>.<pid>-<n>.tmp" in the destination folder (the same file
// system, so the rename is atomic). A destination that is a symbolic link is written through the
// link (its target is replaced). Existing directories, devices, pipes and sockets are refused as
// destinations: renaming a regular file over them would destroy them.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

class OutputFiles {
public:
    // Writes the output's content to `tempPath`; returns false and sets `error` on failure.
    using Writer = std::function<bool(const std::string& tempPath, std::string& error)>;

    OutputFiles() = default;
    ~OutputFiles();  // discard() unless committed
    OutputFiles(const OutputFiles&) = delete;
    OutputFiles& operator=(const OutputFiles&) = delete;

    // Validates `path` as an output of this command (see the rule above). Errors read
    // "cannot write <path>: <reason>". The same file may not be added twice.
    bool add(const std::string& path, std::string& error);

    // Runs `writer` on the temporary file of the added output `path`; a failed writer leaves the
    // command failed (commit() refuses) and its message in `error`.
    bool write(const std::string& path, const Writer& writer, std::string& error);
    bool writeText(const std::string& path, std::string_view text, std::string& error);

    // Flushes every temporary to disk and renames it into place. Refuses when an added output was
    // never written or a write failed. If a rename fails, the outputs already renamed are removed
    // as well, so the command leaves no output.
    bool commit(std::string& error);

    // Removes the temporary files and the folders add() created (only those still empty).
    void discard();

    // The temporary file of the added output `path` (empty when `path` was not added).
    std::string tempPath(const std::string& path) const;

private:
    struct Entry {
        std::string path;    // as given
        std::string target;  // the file that is replaced (symbolic links resolved)
        std::string temp;
        std::string key;  // absolute, canonical folder + file name: detects the same file added twice
        bool written = false;
    };
    Entry* find(const std::string& path);
    const Entry* find(const std::string& path) const;

    std::vector<Entry> m_entries;
    std::vector<std::string> m_createdDirs;  // in creation order
    bool m_failed = false;
    bool m_committed = false;
};

}  // namespace penumbra
