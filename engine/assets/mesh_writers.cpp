// Mesh writers: binary little-endian PLY and OBJ (used by tools and tests).
#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include <fmt/format.h>

#include "engine/assets/mesh.h"

namespace penumbra::assets {
namespace {

bool checkWritable(const std::string& path, const MeshData& mesh, std::string& error) {
    if (mesh.indices.size() % 3 != 0) {
        error = fmt::format("{}: cannot write mesh: index count {} is not a multiple of 3", path,
                            mesh.indices.size());
        return false;
    }
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) {
        error = fmt::format("{}: cannot write mesh: {} normals for {} vertices", path, mesh.normals.size(),
                            mesh.positions.size());
        return false;
    }
    if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size()) {
        error = fmt::format("{}: cannot write mesh: {} texture coordinates for {} vertices", path,
                            mesh.uvs.size(), mesh.positions.size());
        return false;
    }
    for (size_t i = 0; i < mesh.indices.size(); ++i) {
        if (mesh.indices[i] >= mesh.positions.size()) {
            error = fmt::format("{}: cannot write mesh: index {} = {} out of range (vertex count {})", path,
                                i, mesh.indices[i], mesh.positions.size());
            return false;
        }
    }
    return true;
}

bool writeBytes(const std::string& path, const std::string& data, std::string& error) {
    std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
    if (!file) {
        error = fmt::format("{}: cannot open for writing: {}", path, std::strerror(errno));
        return false;
    }
    if (std::fwrite(data.data(), 1, data.size(), file.get()) != data.size()) {
        error = fmt::format("{}: write failed: {}", path, std::strerror(errno));
        return false;
    }
    FILE* raw = file.release();
    if (std::fclose(raw) != 0) {
        error = fmt::format("{}: write failed on close: {}", path, std::strerror(errno));
        return false;
    }
    return true;
}

template <typename T>
void appendLittleEndian(std::string& out, T value) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) {
        for (size_t i = 0; i < sizeof(T) / 2; ++i) {
            std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
        }
    }
    out.append(bytes, sizeof(T));
}

}  // namespace

bool writePly(const std::string& path, const MeshData& mesh, std::string& error) {
    if (!checkWritable(path, mesh, error)) {
        return false;
    }
    const bool normals = !mesh.normals.empty();
    const bool uvs = !mesh.uvs.empty();
    std::string data = fmt::format(
        "ply\nformat binary_little_endian 1.0\ncomment written by penumbra\n"
        "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        mesh.positions.size());
    if (normals) {
        data += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if (uvs) {
        data += "property float u\nproperty float v\n";
    }
    data += fmt::format("element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
                        mesh.indices.size() / 3);
    const size_t vertexBytes = 4 * (3 + (normals ? 3 : 0) + (uvs ? 2 : 0));
    data.reserve(data.size() + mesh.positions.size() * vertexBytes + mesh.indices.size() / 3 * 13);
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
        const glm::vec3& p = mesh.positions[i];
        appendLittleEndian(data, p.x);
        appendLittleEndian(data, p.y);
        appendLittleEndian(data, p.z);
        if (normals) {
            appendLittleEndian(data, mesh.normals[i].x);
            appendLittleEndian(data, mesh.normals[i].y);
            appendLittleEndian(data, mesh.normals[i].z);
        }
        if (uvs) {
            appendLittleEndian(data, mesh.uvs[i].x);
            appendLittleEndian(data, mesh.uvs[i].y);
        }
    }
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        data.push_back(char(3));
        appendLittleEndian(data, mesh.indices[t]);
        appendLittleEndian(data, mesh.indices[t + 1]);
        appendLittleEndian(data, mesh.indices[t + 2]);
    }
    return writeBytes(path, data, error);
}

bool writeObj(const std::string& path, const MeshData& mesh, std::string& error) {
    if (!checkWritable(path, mesh, error)) {
        return false;
    }
    const bool normals = !mesh.normals.empty();
    const bool uvs = !mesh.uvs.empty();
    std::string data = fmt::format("# written by penumbra: {} vertices, {} triangles\n",
                                   mesh.positions.size(), mesh.indices.size() / 3);
    // "{}" prints the shortest text that reads back as the same float.
    for (const glm::vec3& p : mesh.positions) {
        fmt::format_to(std::back_inserter(data), "v {} {} {}\n", p.x, p.y, p.z);
    }
    for (const glm::vec2& t : mesh.uvs) {
        fmt::format_to(std::back_inserter(data), "vt {} {}\n", t.x, t.y);
    }
    for (const glm::vec3& n : mesh.normals) {
        fmt::format_to(std::back_inserter(data), "vn {} {} {}\n", n.x, n.y, n.z);
    }
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        data += 'f';
        for (size_t k = 0; k < 3; ++k) {
            const uint64_t i = uint64_t(mesh.indices[t + k]) + 1;
            if (uvs && normals) {
                fmt::format_to(std::back_inserter(data), " {}/{}/{}", i, i, i);
            } else if (uvs) {
                fmt::format_to(std::back_inserter(data), " {}/{}", i, i);
            } else if (normals) {
                fmt::format_to(std::back_inserter(data), " {}//{}", i, i);
            } else {
                fmt::format_to(std::back_inserter(data), " {}", i);
            }
        }
        data += '\n';
    }
    return writeBytes(path, data, error);
}

}  // namespace penumbra::assets
