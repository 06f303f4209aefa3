// Format dispatch and the helpers shared by the mesh loaders.
#include "engine/assets/mesh.h"

#include <sys/mman.h>
#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <utility>

#include <fmt/format.h>

#include "engine/assets/mesh_internal.h"

namespace penumbra::assets {
namespace detail {
namespace {
constexpr size_t kHugePage = size_t(2) << 20;
}  // namespace

FileBytes::FileBytes(FileBytes&& other) noexcept { *this = std::move(other); }

FileBytes& FileBytes::operator=(FileBytes&& other) noexcept {
    if (this != &other) {
        release();
        m_data = std::exchange(other.m_data, nullptr);
        m_size = std::exchange(other.m_size, 0);
        m_mapping = std::exchange(other.m_mapping, nullptr);
        m_mappingBytes = std::exchange(other.m_mappingBytes, 0);
    }
    return *this;
}

bool FileBytes::allocate(size_t bytes) {
    release();
    if (bytes >= 2 * kHugePage) {
        const size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
        const size_t length = rounded + kHugePage;  // room to align the start to a huge page
        void* mapping = ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (mapping != MAP_FAILED) {
            const uintptr_t aligned =
                (reinterpret_cast<uintptr_t>(mapping) + kHugePage - 1) & ~uintptr_t(kHugePage - 1);
            m_data = reinterpret_cast<char*>(aligned);
            ::madvise(m_data, rounded, MADV_HUGEPAGE);
            m_mapping = mapping;
            m_mappingBytes = length;
            m_size = bytes;
            return true;
        }
    }
    m_data = new (std::nothrow) char[bytes];
    m_size = m_data ? bytes : 0;
    return m_data != nullptr;
}

void FileBytes::release() {
    if (m_mapping) {
        ::munmap(m_mapping, m_mappingBytes);
    } else {
        delete[] m_data;
    }
    m_data = nullptr;
    m_size = 0;
    m_mapping = nullptr;
    m_mappingBytes = 0;
}

void adviseHugePages(const void* p, size_t bytes) {
    const uintptr_t begin = (reinterpret_cast<uintptr_t>(p) + kHugePage - 1) & ~uintptr_t(kHugePage - 1);
    const uintptr_t end = (reinterpret_cast<uintptr_t>(p) + bytes) & ~uintptr_t(kHugePage - 1);
    if (p && end > begin) {
        ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
    }
}

bool readWholeFile(const std::string& path, uint64_t maxBytes, FileBytes& bytes, std::string& error) {
    bytes.release();
    if (path.empty()) {
        error = "(empty path): no file name given";
        return false;
    }
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) {
        error = fmt::format("{}: cannot open file: {}", path, std::strerror(errno));
        return false;
    }
    if (S_ISDIR(st.st_mode)) {
        error = fmt::format("{}: cannot open file: is a directory, not a file", path);
        return false;
    }
    if (!S_ISREG(st.st_mode)) {
        error = fmt::format("{}: cannot open file: not a regular file", path);
        return false;
    }
    const uint64_t size = uint64_t(st.st_size);
    if (size == 0) {
        error = fmt::format("{}: empty file (0 bytes)", path);
        return false;
    }
    if (size > maxBytes) {
        error = fmt::format("{}: file too large ({} bytes, limit {} bytes)", path, size, maxBytes);
        return false;
    }
    std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!file) {
        error = fmt::format("{}: cannot open file: {}", path, std::strerror(errno));
        return false;
    }
    if (!bytes.allocate(size_t(size))) {
        error = fmt::format("{}: out of memory reading {} bytes", path, size);
        return false;
    }
    const size_t got = std::fread(bytes.data(), 1, bytes.size(), file.get());
    if (got != bytes.size()) {
        error = fmt::format("{}: read error after {} of {} bytes", path, got, size);
        bytes.release();
        return false;
    }
    return true;
}

std::string lowerExtension(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    const size_t dot = path.find_last_of('.');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) {
        return {};
    }
    std::string ext = path.substr(dot + 1);
    for (char& c : ext) {
        if (c >= 'A' && c <= 'Z') {
            c = char(c - 'A' + 'a');
        }
    }
    return ext;
}

bool validateMesh(const MeshData& mesh, const MeshLoadLimits& limits, std::string& error) {
    const std::string& path = mesh.sourcePath;
    if (mesh.positions.empty() || mesh.indices.empty()) {
        error = fmt::format("{}: no triangles found ({} vertices, {} triangles)", path, mesh.positions.size(),
                            mesh.indices.size() / 3);
        return false;
    }
    if (mesh.positions.size() > limits.maxVertices) {
        error = fmt::format("{}: too many vertices ({}, limit {})", path, mesh.positions.size(),
                            limits.maxVertices);
        return false;
    }
    if (mesh.indices.size() % 3 != 0) {
        error = fmt::format("{}: index count {} is not a multiple of 3", path, mesh.indices.size());
        return false;
    }
    if (mesh.indices.size() / 3 > limits.maxTriangles) {
        error = fmt::format("{}: too many triangles ({}, limit {})", path, mesh.indices.size() / 3,
                            limits.maxTriangles);
        return false;
    }
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) {
        error =
            fmt::format("{}: {} normals for {} vertices", path, mesh.normals.size(), mesh.positions.size());
        return false;
    }
    if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size()) {
        error = fmt::format("{}: {} texture coordinates for {} vertices", path, mesh.uvs.size(),
                            mesh.positions.size());
        return false;
    }
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
        const glm::vec3& p = mesh.positions[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            error = fmt::format("{}: vertex {} has a non-finite position (NaN or inf: {} {} {})", path, i,
                                p.x, p.y, p.z);
            return false;
        }
    }
    for (size_t i = 0; i < mesh.normals.size(); ++i) {
        const glm::vec3& n = mesh.normals[i];
        if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) {
            error = fmt::format("{}: vertex {} has a non-finite normal (NaN or inf)", path, i);
            return false;
        }
    }
    for (size_t i = 0; i < mesh.uvs.size(); ++i) {
        const glm::vec2& t = mesh.uvs[i];
        if (!std::isfinite(t.x) || !std::isfinite(t.y)) {
            error = fmt::format("{}: vertex {} has a non-finite texture coordinate (NaN or inf)", path, i);
            return false;
        }
    }
    const size_t vertexCount = mesh.positions.size();
    for (size_t i = 0; i < mesh.indices.size(); ++i) {
        if (mesh.indices[i] >= vertexCount) {
            error = fmt::format("{}: triangle {} references vertex index {} out of range (vertex count {})",
                                path, i / 3, mesh.indices[i], vertexCount);
            return false;
        }
    }
    return true;
}

}  // namespace detail

bool loadMesh(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits) {
    const std::string ext = detail::lowerExtension(path);
    if (ext == "ply") {
        return loadPly(path, out, error, limits);
    }
    if (ext == "obj") {
        return loadObj(path, out, error, limits);
    }
    if (ext == "gltf" || ext == "glb") {
        return loadGltfMesh(path, out, error, limits);
    }
    out = MeshData{};
    error = fmt::format("{}: unknown mesh format '.{}' (supported: .ply, .obj, .gltf, .glb)", path, ext);
    return false;
}

}  // namespace penumbra::assets
