// Shared glTF machinery (see gltf_internal.h): tinygltf 2.7 from Debian (its shared library provides
// the implementation; nothing here defines TINYGLTF_IMPLEMENTATION). tinygltf trusts its input far
// more than shared/design.md "Malformed-asset policy" allows, so this file:
//  - checks the GLB container and the JSON nesting depth before tinygltf sees them,
//  - checks every buffer/image URI (only data: URIs and relative paths without '..'), and installs
//    file-system callbacks that confine every read to the asset's directory (symlinks resolved),
//    never expand '~' or variables and apply the whole-file cap; tinygltf never decodes images
//    (their encoded bytes may be collected for the caller to decode),
//  - validates every bufferView and accessor it reads with overflow-safe range checks, component
//    types, strides, index ranges and finiteness, and the node graph (child indices, two parents,
//    cycles) before anyone walks it.
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string_view>

#include <fmt/format.h>
#include <glm/glm.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/assets/gltf_internal.h"
#include "engine/assets/mesh_internal.h"
#include "engine/core/json_depth.h"

namespace penumbra::assets::gltf {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxJsonDepth = 64;
constexpr uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;
constexpr uint32_t kChunkBin = 0x004E4942;

uint32_t readU32(const char* p) {
    uint32_t v;
    std::memcpy(&v, p, 4);
    return v;  // GLB is little-endian, as is every platform this builds on
}

// binLength: the BIN chunk's length, or -1 when the container has none.
bool checkGlbContainer(const std::string& path, const detail::FileBytes& bytes, std::string_view& json,
                       int64_t& binLength, std::string& error) {
    binLength = -1;
    const size_t size = bytes.size();
    if (size < 12 || readU32(bytes.data()) != kGlbMagic) {
        error = fmt::format("{}: not a GLB file (bad magic, expected 'glTF')", path);
        return false;
    }
    const uint32_t version = readU32(bytes.data() + 4);
    if (version != 2) {
        error = fmt::format("{}: unsupported GLB container version {} (expected 2)", path, version);
        return false;
    }
    const uint32_t length = readU32(bytes.data() + 8);
    if (length > size || size < 20) {
        error = fmt::format("{}: truncated GLB: header says {} bytes, file has {}", path, length, size);
        return false;
    }
    if (length < 20) {
        error = fmt::format("{}: invalid GLB: total length {} is smaller than the headers", path, length);
        return false;
    }
    const uint32_t jsonLength = readU32(bytes.data() + 12);
    const uint32_t jsonType = readU32(bytes.data() + 16);
    if (jsonType != kChunkJson) {
        error = fmt::format("{}: invalid GLB: first chunk is not JSON", path);
        return false;
    }
    if (jsonLength == 0 || jsonLength > length - 20) {
        error = fmt::format("{}: invalid GLB: JSON chunk length {} exceeds the file (truncated file?)", path,
                            jsonLength);
        return false;
    }
    const uint64_t binStart = 20ull + jsonLength;
    if (binStart < length) {
        const uint64_t left = length - binStart;
        if (left < 8) {
            error = fmt::format("{}: invalid GLB: truncated chunk header after the JSON chunk", path);
            return false;
        }
        const uint32_t chunkLength = readU32(bytes.data() + binStart);
        const uint32_t binType = readU32(bytes.data() + binStart + 4);
        if (binType == kChunkBin && chunkLength > left - 8) {
            error = fmt::format("{}: invalid GLB: BIN chunk length {} exceeds the file (truncated file?)",
                                path, chunkLength);
            return false;
        }
        if (binType == kChunkBin) {
            binLength = chunkLength;
        }
    }
    json = std::string_view(bytes.data() + 20, jsonLength);
    return true;
}

// A GLB's buffer 0 without a uri is the BIN chunk: its byteLength must be an integer from 1 (the
// schema's minimum) to the chunk's length, and the chunk must exist. Checked here because tinygltf
// answers some of these cases with its internal exceptions (e.g. "vector::_M_range_check").
bool checkGlbBuffer(const std::string& path, const nlohmann::json& doc, int64_t binLength,
                    std::string& error) {
    const auto buffers = doc.find("buffers");
    if (buffers == doc.end() || !buffers->is_array() || buffers->empty() || !(*buffers)[0].is_object() ||
        (*buffers)[0].contains("uri")) {
        return true;
    }
    const nlohmann::json& buffer = (*buffers)[0];
    if (binLength < 0) {
        error = fmt::format(
            "{}: invalid GLB: buffer 0 has no uri, so it is the BIN chunk, but the file has none", path);
        return false;
    }
    const auto length = buffer.find("byteLength");
    if (length == buffer.end() || !length->is_number_integer()) {
        error = fmt::format("{}: invalid GLB: buffer 0 (the BIN chunk) has no integer byteLength", path);
        return false;
    }
    if (!length->is_number_unsigned() || length->get<uint64_t>() == 0 ||
        length->get<uint64_t>() > uint64_t(binLength)) {
        error = fmt::format(
            "{}: invalid GLB: buffer 0 (the BIN chunk) has byteLength {}, but it must be at least 1 and at "
            "most "
            "the BIN chunk's {} bytes",
            path, length->dump(), binLength);
        return false;
    }
    return true;
}

bool checkJsonDepth(const std::string& path, std::string_view json, std::string& error) {
    size_t offset = 0;
    if (!jsonDepthWithin(json, kMaxJsonDepth, offset)) {
        error = fmt::format("{}: JSON nested deeper than {} levels (refused)", path, kMaxJsonDepth);
        return false;
    }
    return true;
}

int hexValue(char c) {
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    return -1;
}

std::string percentDecode(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    for (size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%' && i + 2 < s.size() && hexValue(s[i + 1]) >= 0 && hexValue(s[i + 2]) >= 0) {
            out.push_back(char(hexValue(s[i + 1]) * 16 + hexValue(s[i + 2])));
            i += 2;
        } else {
            out.push_back(s[i]);
        }
    }
    return out;
}

// Only data: URIs and relative paths that stay in the asset's directory.
bool checkUri(const std::string& path, const std::string& what, const std::string& uri, std::string& error) {
    if (uri.rfind("data:", 0) == 0) {
        return true;
    }
    const std::string decoded = percentDecode(uri);
    auto refuse = [&](std::string_view why) {
        error = fmt::format(
            "{}: {} URI '{}' refused: {} (only data: URIs and relative paths inside the asset's "
            "directory are allowed)",
            path, what, uri, why);
        return false;
    };
    if (decoded.empty()) {
        return refuse("empty URI");
    }
    if (decoded.find('\0') != std::string::npos) {
        return refuse("NUL character");
    }
    if (decoded[0] == '/' || decoded[0] == '\\' || decoded[0] == '~') {
        return refuse("absolute path");
    }
    const size_t colon = decoded.find(':');
    const size_t slash = decoded.find('/');
    if (colon != std::string::npos && (slash == std::string::npos || colon < slash)) {
        return refuse("absolute path or URI scheme");
    }
    if (decoded.find('\\') != std::string::npos) {
        return refuse("backslash in path");
    }
    size_t start = 0;
    while (start <= decoded.size()) {
        size_t end = decoded.find('/', start);
        if (end == std::string::npos) {
            end = decoded.size();
        }
        if (decoded.compare(start, end - start, "..") == 0) {
            return refuse("'..' escapes the asset directory");
        }
        start = end + 1;
    }
    return true;
}

bool checkUris(const std::string& path, std::string_view json, nlohmann::json& doc, std::string& error) {
    try {
        doc = nlohmann::json::parse(json.begin(), json.end());
    } catch (const nlohmann::json::exception& e) {
        error = fmt::format("{}: bad JSON: {}", path, e.what());
        return false;
    }
    if (!doc.is_object()) {
        error = fmt::format("{}: bad JSON: the top level is not an object", path);
        return false;
    }
    for (const char* section : {"buffers", "images"}) {
        const auto it = doc.find(section);
        if (it == doc.end() || !it->is_array()) {
            continue;
        }
        for (size_t i = 0; i < it->size(); ++i) {
            const nlohmann::json& entry = (*it)[i];
            if (!entry.is_object()) {
                continue;
            }
            const auto uri = entry.find("uri");
            if (uri == entry.end()) {
                continue;
            }
            const std::string what =
                fmt::format("{} {}", std::string_view(section).substr(0, std::strlen(section) - 1), i);
            if (!uri->is_string()) {
                error = fmt::format("{}: {} 'uri' is not a string", path, what);
                return false;
            }
            if (!checkUri(path, what, uri->get<std::string>(), error)) {
                return false;
            }
        }
    }
    return true;
}

// Confines tinygltf's file access to the asset's directory.
struct FsContext {
    fs::path baseDir;  // canonical
    uint64_t maxFileBytes = 0;
    std::string violation;
};

bool insideBase(const FsContext& ctx, const std::string& file, fs::path& resolved) {
    std::error_code ec;
    resolved = fs::weakly_canonical(fs::absolute(fs::path(file), ec), ec);
    if (ec) {
        return false;
    }
    const std::string base = ctx.baseDir.native();
    const std::string full = resolved.native();
    return full.size() > base.size() && full.compare(0, base.size(), base) == 0 &&
           (base.back() == '/' || full[base.size()] == '/');
}

bool fsFileExists(const std::string& file, void* user) {
    auto* ctx = static_cast<FsContext*>(user);
    fs::path resolved;
    if (!insideBase(*ctx, file, resolved)) {
        return false;
    }
    std::error_code ec;
    return fs::is_regular_file(resolved, ec);
}

std::string fsExpandFilePath(const std::string& file, void*) { return file; }

bool fsReadWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& file, void* user) {
    auto* ctx = static_cast<FsContext*>(user);
    fs::path resolved;
    if (!insideBase(*ctx, file, resolved)) {
        ctx->violation = fmt::format("'{}' is outside the asset directory", file);
        if (err) {
            *err = ctx->violation;
        }
        return false;
    }
    detail::FileBytes bytes;
    std::string readError;
    if (!detail::readWholeFile(resolved.native(), ctx->maxFileBytes, bytes, readError)) {
        if (err) {
            *err = readError;
        }
        return false;
    }
    out->assign(bytes.data(), bytes.data() + bytes.size());
    return true;
}

bool fsWriteWholeFile(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
    if (err) {
        *err = "writing is disabled";
    }
    return false;
}

std::string firstLine(const std::string& s) {
    std::string line = s.substr(0, s.find('\n'));
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) {
        line.pop_back();
    }
    return line;
}

int componentCount(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR:
            return 1;
        case TINYGLTF_TYPE_VEC2:
            return 2;
        case TINYGLTF_TYPE_VEC3:
            return 3;
        case TINYGLTF_TYPE_VEC4:
            return 4;
        case TINYGLTF_TYPE_MAT2:
            return 4;
        case TINYGLTF_TYPE_MAT3:
            return 9;
        case TINYGLTF_TYPE_MAT4:
            return 16;
        default:
            return 0;
    }
}

size_t componentSize(int componentType) {
    switch (componentType) {
        case TINYGLTF_COMPONENT_TYPE_BYTE:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return 1;
        case TINYGLTF_COMPONENT_TYPE_SHORT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
            return 2;
        case TINYGLTF_COMPONENT_TYPE_INT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        case TINYGLTF_COMPONENT_TYPE_FLOAT:
            return 4;
        case TINYGLTF_COMPONENT_TYPE_DOUBLE:
            return 8;
        default:
            return 0;
    }
}

const char* typeName(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR:
            return "SCALAR";
        case TINYGLTF_TYPE_VEC2:
            return "VEC2";
        case TINYGLTF_TYPE_VEC3:
            return "VEC3";
        case TINYGLTF_TYPE_VEC4:
            return "VEC4";
        case TINYGLTF_TYPE_MAT2:
            return "MAT2";
        case TINYGLTF_TYPE_MAT3:
            return "MAT3";
        case TINYGLTF_TYPE_MAT4:
            return "MAT4";
        default:
            return "unknown type";
    }
}

const char* componentTypeName(int componentType) {
    switch (componentType) {
        case TINYGLTF_COMPONENT_TYPE_BYTE:
            return "byte";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return "unsigned byte";
        case TINYGLTF_COMPONENT_TYPE_SHORT:
            return "short";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
            return "unsigned short";
        case TINYGLTF_COMPONENT_TYPE_INT:
            return "int";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
            return "unsigned int";
        case TINYGLTF_COMPONENT_TYPE_FLOAT:
            return "float";
        case TINYGLTF_COMPONENT_TYPE_DOUBLE:
            return "double";
        default:
            return "unknown component type";
    }
}

// The range [offset, offset + (count-1)*stride + elem) lies within [0, size): overflow-safe.
bool rangeFits(uint64_t size, uint64_t offset, uint64_t count, uint64_t elem, uint64_t stride) {
    if (count == 0) {
        return offset <= size;
    }
    return offset <= size && elem <= size - offset && count - 1 <= (size - offset - elem) / stride;
}

// Image callback: tinygltf hands over the encoded bytes; nothing is decoded here. Bytes of
// bufferView images are not touched (tinygltf passes them without checking the bufferView's range;
// the caller reads them from the validated bufferView instead).
struct ImageCollector {
    bool collect = false;
    std::vector<std::vector<uint8_t>>* bytes = nullptr;
    std::vector<char>* read = nullptr;
};

bool collectImage(tinygltf::Image* image, const int index, std::string*, std::string*, int, int,
                  const unsigned char* data, int size, void* user) {
    auto* collector = static_cast<ImageCollector*>(user);
    if (!collector || !collector->collect || !image || image->bufferView >= 0 || index < 0 || size <= 0 ||
        !data) {
        return true;
    }
    const size_t i = size_t(index);
    if (collector->bytes->size() <= i) {
        collector->bytes->resize(i + 1);
        collector->read->resize(i + 1, 0);
    }
    (*collector->bytes)[i].assign(data, data + size);
    (*collector->read)[i] = 1;
    return true;
}

const char* roleName(Role r) {
    switch (r) {
        case Role::Position:
            return "POSITION";
        case Role::Normal:
            return "NORMAL";
        case Role::TexCoord:
            return "TEXCOORD_0";
        case Role::Indices:
            return "indices";
    }
    return "?";
}

}  // namespace

bool fail(const std::string& path, std::string& error, std::string_view message) {
    error = path;
    error.append(": ").append(message);
    return false;
}

bool parseGltfFile(const std::string& path, const ParseOptions& options, ParsedGltf& out,
                   std::string& error) {
    detail::FileBytes bytes;
    if (!detail::readWholeFile(path, options.maxFileBytes, bytes, error)) {
        return false;
    }
    const bool isBinary = bytes.size() >= 4 && readU32(bytes.data()) == kGlbMagic;
    if (detail::lowerExtension(path) == "glb" && !isBinary) {
        error = fmt::format("{}: not a GLB file (bad magic, expected 'glTF')", path);
        return false;
    }
    std::string_view json(bytes.data(), bytes.size());
    int64_t binLength = -1;
    if (isBinary && !checkGlbContainer(path, bytes, json, binLength, error)) {
        return false;
    }
    if (bytes.size() > std::numeric_limits<unsigned int>::max()) {
        error = fmt::format("{}: file too large for tinygltf (4 GiB)", path);
        return false;
    }
    nlohmann::json doc;
    if (!checkJsonDepth(path, json, error) || !checkUris(path, json, doc, error) ||
        (isBinary && !checkGlbBuffer(path, doc, binLength, error))) {
        return false;
    }
    if (options.keepJson) {
        out.json = std::move(doc);
    }
    if (options.hashContent) {
        out.contentHash = AssetManager::contentHash(bytes.data(), bytes.size());
    }

    std::error_code ec;
    FsContext ctx;
    ctx.baseDir = fs::weakly_canonical(fs::absolute(fs::path(path), ec).parent_path(), ec);
    if (ec) {
        error = fmt::format("{}: cannot resolve the asset directory: {}", path, ec.message());
        return false;
    }
    ctx.maxFileBytes = options.maxFileBytes;

    tinygltf::TinyGLTF loader;
    tinygltf::FsCallbacks callbacks{};
    callbacks.FileExists = &fsFileExists;
    callbacks.ExpandFilePath = &fsExpandFilePath;
    callbacks.ReadWholeFile = &fsReadWholeFile;
    callbacks.WriteWholeFile = &fsWriteWholeFile;
    callbacks.user_data = &ctx;
    loader.SetFsCallbacks(callbacks);
    ImageCollector collector{options.collectImages, &out.imageBytes, &out.imageRead};
    loader.SetImageLoader(&collectImage, &collector);

    std::string err;
    std::string warn;
    bool ok = false;
    if (isBinary) {
        ok = loader.LoadBinaryFromMemory(&out.model, &err, &warn,
                                         reinterpret_cast<const unsigned char*>(bytes.data()),
                                         static_cast<unsigned int>(bytes.size()), ctx.baseDir.native());
    } else {
        ok = loader.LoadASCIIFromString(&out.model, &err, &warn, bytes.data(),
                                        static_cast<unsigned int>(bytes.size()), ctx.baseDir.native());
    }
    if (!ctx.violation.empty()) {
        error = fmt::format("{}: refused to read {}", path, ctx.violation);
        return false;
    }
    if (!ok) {
        error = fmt::format("{}: invalid glTF: {}", path,
                            err.empty() ? std::string("parse error") : firstLine(err));
        return false;
    }
    if (options.collectImages) {
        out.imageBytes.resize(out.model.images.size());
        out.imageRead.resize(out.model.images.size(), 0);
    }
    return true;
}

bool checkBufferViews(const std::string& path, const tinygltf::Model& model, std::string& error) {
    for (size_t i = 0; i < model.bufferViews.size(); ++i) {
        const tinygltf::BufferView& bv = model.bufferViews[i];
        if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size()) {
            return fail(path, error,
                        fmt::format("bufferView {}: buffer index {} out of range ({} buffers)", i, bv.buffer,
                                    model.buffers.size()));
        }
        const uint64_t size = model.buffers[size_t(bv.buffer)].data.size();
        if (!rangeFits(size, bv.byteOffset, 1, bv.byteLength, 1)) {
            return fail(path, error,
                        fmt::format("bufferView {}: range offset {} + length {} is out of range of "
                                    "buffer {} ({} bytes)",
                                    i, bv.byteOffset, bv.byteLength, bv.buffer, size));
        }
    }
    return true;
}

bool checkNodeGraph(const std::string& path, const tinygltf::Model& model, std::vector<int>& parent,
                    std::string& error) {
    const size_t n = model.nodes.size();
    parent.assign(n, -1);
    for (size_t i = 0; i < n; ++i) {
        const tinygltf::Node& node = model.nodes[i];
        if (node.mesh < -1 || (node.mesh >= 0 && size_t(node.mesh) >= model.meshes.size())) {
            return fail(path, error,
                        fmt::format("node {}: mesh index {} out of range ({} meshes)", i, node.mesh,
                                    model.meshes.size()));
        }
        for (int c : node.children) {
            if (c < 0 || size_t(c) >= n) {
                return fail(path, error,
                            fmt::format("node {}: child index {} out of range ({} nodes)", i, c, n));
            }
            if (size_t(c) == i) {
                return fail(path, error, fmt::format("node graph has a cycle: node {} is its own child", i));
            }
            if (parent[size_t(c)] >= 0) {
                return fail(path, error,
                            fmt::format("node {} has two parents (nodes {} and {}): the node graph "
                                        "must be a tree",
                                        c, parent[size_t(c)], i));
            }
            parent[size_t(c)] = int(i);
        }
    }
    // With at most one parent each, a node not reachable from a root lies on a cycle.
    std::vector<char> reached(n, 0);
    std::vector<int> stack;
    for (size_t i = 0; i < n; ++i) {
        if (parent[i] < 0) {
            stack.push_back(int(i));
        }
    }
    while (!stack.empty()) {
        const int v = stack.back();
        stack.pop_back();
        reached[size_t(v)] = 1;
        for (int c : model.nodes[size_t(v)].children) {
            stack.push_back(c);
        }
    }
    for (size_t i = 0; i < n; ++i) {
        if (!reached[i]) {
            return fail(path, error, fmt::format("node graph has a cycle (through node {})", i));
        }
    }
    return true;
}

bool chooseRoots(const std::string& path, const tinygltf::Model& model, const std::vector<int>& parent,
                 std::vector<int>& roots, std::string& error) {
    const auto& scenes = model.scenes;
    if (model.defaultScene >= 0 && size_t(model.defaultScene) >= scenes.size()) {
        return fail(
            path, error,
            fmt::format("default scene {} out of range ({} scenes)", model.defaultScene, scenes.size()));
    }
    if (!scenes.empty()) {
        const size_t s = model.defaultScene >= 0 ? size_t(model.defaultScene) : 0;
        std::vector<char> listed(model.nodes.size(), 0);
        for (int r : scenes[s].nodes) {
            if (r < 0 || size_t(r) >= model.nodes.size()) {
                return fail(
                    path, error,
                    fmt::format("scene {}: node index {} out of range ({} nodes)", s, r, model.nodes.size()));
            }
            if (listed[size_t(r)]) {
                // Each listing would instance the whole tree again (a few bytes of file per copy).
                return fail(
                    path, error,
                    fmt::format("scene {}: node {} is listed twice in 'nodes' (the glTF schema requires "
                                "unique root nodes)",
                                s, r));
            }
            listed[size_t(r)] = 1;
            if (parent[size_t(r)] >= 0) {
                return fail(path, error,
                            fmt::format("scene {}: node {} is not a root node (its parent is node {})", s, r,
                                        parent[size_t(r)]));
            }
            roots.push_back(r);
        }
        return true;
    }
    for (size_t i = 0; i < model.nodes.size(); ++i) {
        if (parent[i] < 0) {
            roots.push_back(int(i));
        }
    }
    return true;
}

namespace {
bool finiteAll(const std::vector<double>& v) {
    for (double d : v) {
        if (!std::isfinite(d)) {
            return false;
        }
    }
    return true;
}
}  // namespace

glm::dmat4 NodeTransform::toMatrix() const {
    if (isMatrix) {
        return matrix;
    }
    const glm::dmat3 r = glm::mat3_cast(rotation);
    glm::dmat4 m(1.0);
    for (int c = 0; c < 3; ++c) {
        for (int row = 0; row < 3; ++row) {
            m[c][row] = r[c][row] * scale[c];
        }
    }
    m[3] = glm::dvec4(translation, 1.0);
    return m;
}

bool readNodeTransform(const std::string& path, const tinygltf::Model& model, int index, NodeTransform& out,
                       std::string& error) {
    const tinygltf::Node& node = model.nodes[size_t(index)];
    if (!node.matrix.empty()) {
        if (node.matrix.size() != 16 || !finiteAll(node.matrix)) {
            return fail(path, error, fmt::format("node {}: matrix must have 16 finite numbers", index));
        }
        out = NodeTransform{};
        out.isMatrix = true;
        for (int c = 0; c < 4; ++c) {
            for (int r = 0; r < 4; ++r) {
                out.matrix[c][r] = node.matrix[size_t(c * 4 + r)];
            }
        }
        return true;
    }
    glm::dvec3 t(0.0);
    glm::dquat q(1.0, 0.0, 0.0, 0.0);
    glm::dvec3 s(1.0);
    if (!node.translation.empty()) {
        if (node.translation.size() != 3 || !finiteAll(node.translation)) {
            return fail(path, error, fmt::format("node {}: translation must have 3 finite numbers", index));
        }
        t = glm::dvec3(node.translation[0], node.translation[1], node.translation[2]);
    }
    if (!node.rotation.empty()) {
        if (node.rotation.size() != 4 || !finiteAll(node.rotation)) {
            return fail(path, error, fmt::format("node {}: rotation must have 4 finite numbers", index));
        }
        // glTF stores x, y, z, w; glm::dquat's constructor takes w first.
        q = glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
        const double len = glm::length(q);
        if (!(len > 1e-12)) {
            return fail(path, error, fmt::format("node {}: rotation quaternion has zero length", index));
        }
        q = q / len;
    }
    if (!node.scale.empty()) {
        if (node.scale.size() != 3 || !finiteAll(node.scale)) {
            return fail(path, error, fmt::format("node {}: scale must have 3 finite numbers", index));
        }
        s = glm::dvec3(node.scale[0], node.scale[1], node.scale[2]);
    }
    out = NodeTransform{};
    out.translation = t;
    out.rotation = q;
    out.scale = s;
    return true;
}

bool AccessorReader::read(int index, Role role, uint64_t maxCount, std::vector<float>& floats,
                          std::vector<uint32_t>& ints, std::string& error) const {
    const char* rn = roleName(role);
    if (index < 0 || size_t(index) >= m_model.accessors.size()) {
        return fail(m_path, error,
                    fmt::format("{} accessor index {} out of range ({} accessors)", rn, index,
                                m_model.accessors.size()));
    }
    const tinygltf::Accessor& acc = m_model.accessors[size_t(index)];
    const int ct = acc.componentType;
    const int comps = componentCount(acc.type);
    bool typeOk = false;
    switch (role) {
        case Role::Position:
        case Role::Normal:
            typeOk = acc.type == TINYGLTF_TYPE_VEC3 && ct == TINYGLTF_COMPONENT_TYPE_FLOAT;
            break;
        case Role::TexCoord:
            typeOk = acc.type == TINYGLTF_TYPE_VEC2 &&
                     (ct == TINYGLTF_COMPONENT_TYPE_FLOAT ||
                      (acc.normalized && (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                          ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT)));
            break;
        case Role::Indices:
            typeOk =
                acc.type == TINYGLTF_TYPE_SCALAR && !acc.normalized &&
                (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                 ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT || ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
            break;
    }
    if (!typeOk) {
        const char* expected = role == Role::Indices    ? "SCALAR of unsigned byte/short/int"
                               : role == Role::TexCoord ? "VEC2 of float or normalized unsigned byte/short"
                                                        : "VEC3 of float";
        return fail(m_path, error,
                    fmt::format("accessor {} used as {}: unsupported component type ({}{} {}; expected {})",
                                index, rn, acc.normalized ? "normalized " : "", componentTypeName(ct),
                                typeName(acc.type), expected));
    }
    if (acc.count > maxCount) {
        return fail(
            m_path, error,
            fmt::format("accessor {} ({}): count {} exceeds the limit {}", index, rn, acc.count, maxCount));
    }
    const size_t csize = componentSize(ct);
    const uint64_t elem = csize * uint64_t(comps);
    const uint64_t count = acc.count;

    // Raw bytes of every element (tightly packed) gathered first; conversion below.
    std::vector<unsigned char> raw;
    if (acc.bufferView >= 0) {
        if (size_t(acc.bufferView) >= m_model.bufferViews.size()) {
            return fail(
                m_path, error,
                fmt::format("accessor {} ({}): bufferView index {} out of range", index, rn, acc.bufferView));
        }
        const tinygltf::BufferView& bv = m_model.bufferViews[size_t(acc.bufferView)];
        if (bv.byteStride != 0 && bv.byteStride < elem) {
            return fail(m_path, error,
                        fmt::format("accessor {} ({}): bufferView {} byteStride {} is smaller than the "
                                    "element size {}",
                                    index, rn, acc.bufferView, bv.byteStride, elem));
        }
        const uint64_t stride = bv.byteStride != 0 ? bv.byteStride : elem;
        if (!rangeFits(bv.byteLength, acc.byteOffset, count, elem, stride)) {
            return fail(m_path, error,
                        fmt::format("accessor {} ({}): byteOffset {} + count {} x stride {} is out of "
                                    "range of bufferView {} ({} bytes)",
                                    index, rn, acc.byteOffset, count, stride, acc.bufferView, bv.byteLength));
        }
        const unsigned char* base =
            m_model.buffers[size_t(bv.buffer)].data.data() + bv.byteOffset + acc.byteOffset;
        raw.resize(size_t(count * elem));
        for (uint64_t i = 0; i < count; ++i) {
            std::memcpy(raw.data() + i * elem, base + i * stride, size_t(elem));
        }
    } else if (!acc.sparse.isSparse) {
        return fail(m_path, error,
                    fmt::format("accessor {} ({}) has no bufferView and no sparse data", index, rn));
    } else {
        raw.assign(size_t(count * elem), 0);
    }
    if (acc.sparse.isSparse && !applySparse(index, acc, elem, raw, error)) {
        return false;
    }

    if (role == Role::Indices) {
        ints.resize(size_t(count));
        for (uint64_t i = 0; i < count; ++i) {
            const unsigned char* p = raw.data() + i * elem;
            if (csize == 1) {
                ints[size_t(i)] = *p;
            } else if (csize == 2) {
                uint16_t v;
                std::memcpy(&v, p, 2);
                ints[size_t(i)] = v;
            } else {
                uint32_t v;
                std::memcpy(&v, p, 4);
                ints[size_t(i)] = v;
            }
        }
        return true;
    }
    floats.resize(size_t(count) * size_t(comps));
    for (uint64_t i = 0; i < count * uint64_t(comps); ++i) {
        const unsigned char* p = raw.data() + i * csize;
        float v = 0.0f;
        if (ct == TINYGLTF_COMPONENT_TYPE_FLOAT) {
            std::memcpy(&v, p, 4);
            if (!std::isfinite(v)) {
                return fail(m_path, error,
                            fmt::format("accessor {} ({}): element {} is not a finite number (NaN or inf)",
                                        index, rn, i / uint64_t(comps)));
            }
        } else if (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
            v = float(*p) / 255.0f;
        } else {
            uint16_t u;
            std::memcpy(&u, p, 2);
            v = float(u) / 65535.0f;
        }
        floats[size_t(i)] = v;
    }
    return true;
}

bool AccessorReader::applySparse(int index, const tinygltf::Accessor& acc, uint64_t elem,
                                 std::vector<unsigned char>& raw, std::string& error) const {
    const auto& sp = acc.sparse;
    if (sp.count < 1 || uint64_t(sp.count) > acc.count) {
        return fail(m_path, error,
                    fmt::format("accessor {}: sparse count {} out of range (accessor count {})", index,
                                sp.count, acc.count));
    }
    const int ict = sp.indices.componentType;
    const size_t isize =
        (ict == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE || ict == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
         ict == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
            ? componentSize(ict)
            : 0;
    if (isize == 0) {
        return fail(
            m_path, error,
            fmt::format("accessor {}: sparse indices have unsupported component type {}", index, ict));
    }
    const unsigned char* indexData = nullptr;
    const unsigned char* valueData = nullptr;
    if (!sparseView(index, "indices", sp.indices.bufferView, sp.indices.byteOffset, uint64_t(sp.count), isize,
                    indexData, error) ||
        !sparseView(index, "values", sp.values.bufferView, sp.values.byteOffset, uint64_t(sp.count), elem,
                    valueData, error)) {
        return false;
    }
    for (int i = 0; i < sp.count; ++i) {
        uint32_t target = 0;
        if (isize == 1) {
            target = indexData[i];
        } else if (isize == 2) {
            uint16_t v;
            std::memcpy(&v, indexData + size_t(i) * 2, 2);
            target = v;
        } else {
            std::memcpy(&target, indexData + size_t(i) * 4, 4);
        }
        if (target >= acc.count) {
            return fail(m_path, error,
                        fmt::format("accessor {}: sparse index {} out of range (count {})", index, target,
                                    acc.count));
        }
        std::memcpy(raw.data() + uint64_t(target) * elem, valueData + uint64_t(i) * elem, size_t(elem));
    }
    return true;
}

bool AccessorReader::sparseView(int index, const char* what, int view, int offset, uint64_t count,
                                uint64_t elem, const unsigned char*& data, std::string& error) const {
    if (view < 0 || size_t(view) >= m_model.bufferViews.size() || offset < 0) {
        return fail(m_path, error,
                    fmt::format("accessor {}: sparse {} bufferView {} / byteOffset {} out of range", index,
                                what, view, offset));
    }
    const tinygltf::BufferView& bv = m_model.bufferViews[size_t(view)];
    if (!rangeFits(bv.byteLength, uint64_t(offset), count, elem, elem)) {
        return fail(m_path, error,
                    fmt::format("accessor {}: sparse {} out of range of bufferView {}", index, what, view));
    }
    data = m_model.buffers[size_t(bv.buffer)].data.data() + bv.byteOffset + size_t(offset);
    return true;
}

bool readPrimitive(const std::string& path, const tinygltf::Model& model, int meshIndex, size_t primIndex,
                   const MeshLoadLimits& limits, uint64_t vertexBudget, bool wantNormals, bool wantUvs,
                   PrimitiveData& out, std::string& error) {
    out = PrimitiveData{};
    const AccessorReader reader(path, model);
    const size_t pi = primIndex;
    const tinygltf::Primitive& prim = model.meshes[size_t(meshIndex)].primitives[pi];
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode < 0 || mode > TINYGLTF_MODE_TRIANGLE_FAN) {
        return fail(path, error,
                    fmt::format("mesh {} primitive {}: invalid mode {}", meshIndex, pi, prim.mode));
    }
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN) {
        return true;  // points and lines carry no surface
    }
    out.triangles = true;
    const auto posIt = prim.attributes.find("POSITION");
    if (posIt == prim.attributes.end()) {
        return fail(path, error, fmt::format("mesh {} primitive {}: no POSITION attribute", meshIndex, pi));
    }
    std::vector<uint32_t> unused;
    if (!reader.read(posIt->second, Role::Position, vertexBudget, out.positions, unused, error)) {
        return false;
    }
    const size_t vcount = out.positions.size() / 3;
    const auto nIt = prim.attributes.find("NORMAL");
    const auto tIt = prim.attributes.find("TEXCOORD_0");
    if (nIt != prim.attributes.end() && wantNormals) {
        if (!reader.read(nIt->second, Role::Normal, vertexBudget, out.normals, unused, error)) {
            return false;
        }
        if (out.normals.size() / 3 != vcount) {
            return fail(path, error,
                        fmt::format("mesh {} primitive {}: NORMAL count {} differs from POSITION "
                                    "count {}",
                                    meshIndex, pi, out.normals.size() / 3, vcount));
        }
    }
    if (tIt != prim.attributes.end() && wantUvs) {
        if (!reader.read(tIt->second, Role::TexCoord, vertexBudget, out.uvs, unused, error)) {
            return false;
        }
        if (out.uvs.size() / 2 != vcount) {
            return fail(path, error,
                        fmt::format("mesh {} primitive {}: TEXCOORD_0 count {} differs from POSITION "
                                    "count {}",
                                    meshIndex, pi, out.uvs.size() / 2, vcount));
        }
    }

    std::vector<uint32_t> idx;
    if (prim.indices >= 0) {
        std::vector<float> none;
        if (!reader.read(prim.indices, Role::Indices, 3 * limits.maxTriangles + 2, none, idx, error)) {
            return false;
        }
        for (size_t i = 0; i < idx.size(); ++i) {
            if (idx[i] >= vcount) {
                return fail(path, error,
                            fmt::format("mesh {} primitive {}: index {} = {} out of range (vertex "
                                        "count {})",
                                        meshIndex, pi, i, idx[i], vcount));
            }
        }
    } else {
        idx.resize(vcount);
        for (size_t i = 0; i < vcount; ++i) {
            idx[i] = uint32_t(i);
        }
    }
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        if (idx.size() % 3 != 0) {
            return fail(path, error,
                        fmt::format("mesh {} primitive {}: {} indices is not a multiple of 3 for "
                                    "a triangle list",
                                    meshIndex, pi, idx.size()));
        }
        out.indices = std::move(idx);
    } else {
        for (size_t i = 2; i < idx.size(); ++i) {
            if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
                out.indices.insert(out.indices.end(), {idx[0], idx[i - 1], idx[i]});
            } else if (i % 2 == 0) {
                out.indices.insert(out.indices.end(), {idx[i - 2], idx[i - 1], idx[i]});
            } else {
                out.indices.insert(out.indices.end(), {idx[i - 2], idx[i], idx[i - 1]});
            }
        }
    }
    return true;
}

}  // namespace penumbra::assets::gltf
