// Helpers shared by the mesh loaders (internal to engine/assets).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "engine/assets/mesh.h"

namespace penumbra::assets::detail {

// A file's bytes. Large files go into fresh memory advised for transparent huge pages and not
// zero-filled first: on virtual machines with expensive page faults this makes reading a 30 MB
// mesh several times faster.
class FileBytes {
public:
    FileBytes() = default;
    FileBytes(const FileBytes&) = delete;
    FileBytes& operator=(const FileBytes&) = delete;
    FileBytes(FileBytes&& other) noexcept;
    FileBytes& operator=(FileBytes&& other) noexcept;
    ~FileBytes() { release(); }

    bool allocate(size_t bytes);  // false when out of memory
    void release();
    char* data() { return m_data; }
    const char* data() const { return m_data; }
    size_t size() const { return m_size; }

private:
    char* m_data = nullptr;
    size_t m_size = 0;
    void* m_mapping = nullptr;
    size_t m_mappingBytes = 0;
};

// Hints that [p, p + bytes) will be written soon and should use huge pages (no-op for small ranges
// and on systems without madvise).
void adviseHugePages(const void* p, size_t bytes);

// Reads a whole regular file, refusing missing files, directories, special files, empty files and
// files larger than maxBytes. On failure `error` is "<path>: <reason>".
bool readWholeFile(const std::string& path, uint64_t maxBytes, FileBytes& bytes, std::string& error);

// Lower-case extension without the dot ("ply", "glb"), empty if none.
std::string lowerExtension(const std::string& path);

// Checks positions (finite), normals/uvs (empty or one per position, finite), indices (multiple of
// three, each < positions.size()) and the limits; the message starts with mesh.sourcePath.
bool validateMesh(const MeshData& mesh, const MeshLoadLimits& limits, std::string& error);

}  // namespace penumbra::assets::detail
