// STL mesh importer, a shared-library plugin: registers an importer for ".stl" (binary and ASCII)
// that reads triangles into assets::MeshData. Identical vertex positions are welded into one
// vertex (STL stores every triangle's corners separately); facet normals are not kept (MeshData
// normals are per vertex), so `normals` stays empty.
//
// Validation: missing/empty/oversized files, binary files whose size disagrees with the triangle
// count in the header (truncated or trailing bytes), triangle counts over the limit, malformed
// ASCII (unexpected keywords, bad numbers, facets with fewer than three vertices, missing
// `endsolid`), and non-finite vertex coordinates. Every error names the file and the element.
//
// Uses no engine symbol (see engine/plugin/plugin.h): only the PluginContext and header types.
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <vector>

#include "engine/plugin/plugin.h"

namespace {

using penumbra::assets::MeshData;

constexpr uint64_t kMaxFileBytes = penumbra::assets::MeshLoadLimits{}.maxFileBytes;
constexpr uint64_t kMaxTriangles = penumbra::assets::MeshLoadLimits{}.maxTriangles;
constexpr uint64_t kBinaryHeaderBytes = 84;    // 80-byte header + uint32 triangle count
constexpr uint64_t kBinaryTriangleBytes = 50;  // normal, 3 vertices (12 floats), uint16 attribute

// Sets "<path>: <parts...>" and returns false.
template <typename... Parts>
bool failWith(std::string& error, const std::string& path, const Parts&... parts) {
    error.clear();
    error.append(path).append(": ");
    (error.append(parts), ...);
    return false;
}

bool readFile(const std::string& path, std::string& bytes, std::string& error) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (ec || !std::filesystem::exists(status)) return failWith(error, path, "no such file");
    if (!std::filesystem::is_regular_file(status)) return failWith(error, path, "not a regular file");
    const uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) return failWith(error, path, "cannot read its size: ", ec.message());
    if (size == 0) return failWith(error, path, "empty file");
    if (size > kMaxFileBytes) {
        return failWith(error, path, "file is ", std::to_string(size), " bytes, over the limit of ",
                        std::to_string(kMaxFileBytes));
    }
    std::FILE* file = std::fopen(path.c_str(), "rb");
    if (!file) return failWith(error, path, "cannot open: ", std::strerror(errno));
    bytes.resize(size_t(size));
    const size_t got = std::fread(bytes.data(), 1, bytes.size(), file);
    std::fclose(file);
    if (got != bytes.size())
        return failWith(error, path, "read failed after ", std::to_string(got), " bytes");
    return true;
}

// Welds exactly equal positions (-0 and +0 are equal) into one vertex.
class VertexWelder {
public:
    explicit VertexWelder(MeshData& mesh) : m_mesh(mesh) {}

    void reserve(size_t triangles) {
        m_mesh.indices.reserve(triangles * 3);
        m_lookup.reserve(triangles / 2 + 16);
        m_mesh.positions.reserve(triangles / 2 + 16);
    }

    void add(const glm::vec3& p) {
        const glm::vec3 q = p + glm::vec3(0.0f);  // -0 -> +0
        const Key key{std::bit_cast<uint32_t>(q.x), std::bit_cast<uint32_t>(q.y),
                      std::bit_cast<uint32_t>(q.z)};
        auto [it, inserted] = m_lookup.try_emplace(key, uint32_t(m_mesh.positions.size()));
        if (inserted) m_mesh.positions.push_back(q);
        m_mesh.indices.push_back(it->second);
    }

private:
    struct Key {
        uint32_t x, y, z;
        bool operator==(const Key&) const = default;
    };
    struct KeyHash {
        size_t operator()(const Key& k) const {
            uint64_t h = 0x9e3779b97f4a7c15ull;
            for (uint32_t v : {k.x, k.y, k.z}) {
                h ^= v;
                h *= 0xff51afd7ed558ccdull;
                h ^= h >> 33;
            }
            return size_t(h);
        }
    };

    MeshData& m_mesh;
    std::unordered_map<Key, uint32_t, KeyHash> m_lookup;
};

bool finite(const glm::vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// ---- binary ------------------------------------------------------------------------------------

uint32_t readLe32(const char* p) {
    const auto* b = reinterpret_cast<const unsigned char*>(p);
    return uint32_t(b[0]) | (uint32_t(b[1]) << 8) | (uint32_t(b[2]) << 16) | (uint32_t(b[3]) << 24);
}

float readLeFloat(const char* p) { return std::bit_cast<float>(readLe32(p)); }

bool importBinary(const std::string& path, const std::string& bytes, MeshData& out, std::string& error) {
    const uint64_t size = bytes.size();
    if (size < kBinaryHeaderBytes) {
        return failWith(error, path, "truncated binary STL: ", std::to_string(size),
                        " bytes, the header and triangle count alone need 84");
    }
    const uint64_t count = readLe32(bytes.data() + 80);
    if (count == 0) return failWith(error, path, "binary STL with no triangles");
    if (count > kMaxTriangles) {
        return failWith(error, path, "binary STL header claims ", std::to_string(count),
                        " triangles, over the limit of ", std::to_string(kMaxTriangles));
    }
    const uint64_t expected = kBinaryHeaderBytes + count * kBinaryTriangleBytes;
    if (size < expected) {
        return failWith(error, path, "truncated binary STL: the header claims ", std::to_string(count),
                        " triangles (", std::to_string(expected), " bytes) but the file has ",
                        std::to_string(size), " bytes");
    }
    if (size > expected) {
        return failWith(error, path, "binary STL has ", std::to_string(size - expected),
                        " bytes after its last triangle (the header claims ", std::to_string(count),
                        " triangles, ", std::to_string(expected), " bytes)");
    }

    VertexWelder welder(out);
    welder.reserve(size_t(count));
    for (uint64_t t = 0; t < count; ++t) {
        const char* record = bytes.data() + kBinaryHeaderBytes + t * kBinaryTriangleBytes;
        for (int v = 0; v < 3; ++v) {
            const char* corner = record + 12 + v * 12;
            const glm::vec3 p(readLeFloat(corner), readLeFloat(corner + 4), readLeFloat(corner + 8));
            if (!finite(p)) {
                return failWith(error, path, "triangle ", std::to_string(t), " vertex ", std::to_string(v),
                                ": non-finite coordinate");
            }
            welder.add(p);
        }
    }
    return true;
}

// ---- ASCII -------------------------------------------------------------------------------------

class Tokenizer {
public:
    explicit Tokenizer(std::string_view text) : m_text(text) {}

    // The next whitespace-separated token; empty at the end.
    std::string_view next() {
        skipSpace();
        const size_t start = m_pos;
        while (m_pos < m_text.size() && !isSpace(m_text[m_pos])) ++m_pos;
        return m_text.substr(start, m_pos - start);
    }
    bool atEnd() {
        skipSpace();
        return m_pos >= m_text.size();
    }
    // Skips the rest of the current line (e.g. a solid's name).
    void skipLine() {
        while (m_pos < m_text.size() && m_text[m_pos] != '\n') ++m_pos;
    }
    size_t line() const { return m_line; }

private:
    static bool isSpace(char c) {
        return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
    }
    void skipSpace() {
        while (m_pos < m_text.size() && isSpace(m_text[m_pos])) {
            if (m_text[m_pos] == '\n') ++m_line;
            ++m_pos;
        }
    }

    std::string_view m_text;
    size_t m_pos = 0;
    size_t m_line = 1;
};

bool equalsKeyword(std::string_view token, std::string_view keyword) {
    if (token.size() != keyword.size()) return false;
    for (size_t i = 0; i < token.size(); ++i) {
        char c = token[i];
        if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
        if (c != keyword[i]) return false;
    }
    return true;
}

std::string shown(std::string_view token) {
    if (token.empty()) return "end of file";
    std::string out = "'";
    out.append(token.substr(0, 40));
    if (token.size() > 40) out.append("...");
    out.append("'");
    return out;
}

class AsciiParser {
public:
    AsciiParser(const std::string& path, std::string_view text, MeshData& out, std::string& error)
        : m_path(path), m_tokens(text), m_welder(out), m_error(error) {}

    bool parse() {
        if (!expect("solid")) return false;
        m_tokens.skipLine();
        uint64_t triangles = 0;
        std::vector<glm::vec3> loop;
        for (;;) {
            const std::string_view token = m_tokens.next();
            if (equalsKeyword(token, "endsolid")) {
                m_tokens.skipLine();
                if (m_tokens.atEnd()) break;
                // Several solids may follow each other in one file.
                if (!expect("solid")) return false;
                m_tokens.skipLine();
                continue;
            }
            if (!equalsKeyword(token, "facet")) return unexpected("'facet' or 'endsolid'", token);
            glm::vec3 normal;
            if (!expect("normal") || !readVector(normal, false) || !expect("outer") || !expect("loop"))
                return false;
            loop.clear();
            for (;;) {
                const std::string_view word = m_tokens.next();
                if (equalsKeyword(word, "endloop")) break;
                if (!equalsKeyword(word, "vertex")) return unexpected("'vertex' or 'endloop'", word);
                glm::vec3 p;
                if (!readVector(p, true)) return false;
                if (loop.size() >= 1024) return fail("a facet with more than 1024 vertices");
                loop.push_back(p);
            }
            if (loop.size() < 3) {
                return fail(std::string("a facet with ") + std::to_string(loop.size()) +
                            " vertices (needs 3)");
            }
            if (!expect("endfacet")) return false;
            triangles += loop.size() - 2;
            if (triangles > kMaxTriangles) {
                return fail(std::string("more than ") + std::to_string(kMaxTriangles) +
                            " triangles (the limit)");
            }
            for (size_t i = 1; i + 1 < loop.size(); ++i) {  // fan: polygons from non-standard writers
                m_welder.add(loop[0]);
                m_welder.add(loop[i]);
                m_welder.add(loop[i + 1]);
            }
        }
        if (triangles == 0) {
            m_error.clear();
            m_error.append(m_path).append(": ASCII STL with no facets");
            return false;
        }
        return true;
    }

private:
    bool fail(const std::string& reason) {
        return failWith(m_error, m_path, "line ", std::to_string(m_tokens.line()), ": ", reason);
    }
    bool unexpected(std::string_view wanted, std::string_view found) {
        std::string reason = "expected ";
        reason.append(wanted).append(", found ").append(shown(found));
        return fail(reason);
    }
    bool expect(std::string_view keyword) {
        const std::string_view token = m_tokens.next();
        if (equalsKeyword(token, keyword)) return true;
        std::string wanted = "'";
        wanted.append(keyword).append("'");
        return unexpected(wanted, token);
    }
    bool readNumber(float& value, bool requireFinite) {
        std::string_view token = m_tokens.next();
        std::string_view digits = token;
        if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
        const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
        if (token.empty() || ec != std::errc() || end != digits.data() + digits.size()) {
            return unexpected("a number", token);
        }
        if (requireFinite && !std::isfinite(value)) {
            std::string reason = "non-finite vertex coordinate ";
            reason.append(shown(token));
            return fail(reason);
        }
        return true;
    }
    bool readVector(glm::vec3& v, bool requireFinite) {
        return readNumber(v.x, requireFinite) && readNumber(v.y, requireFinite) &&
               readNumber(v.z, requireFinite);
    }

    const std::string& m_path;
    Tokenizer m_tokens;
    VertexWelder m_welder;
    std::string& m_error;
};

// ASCII files start with "solid" and contain no NUL byte; binary files may start with "solid"
// too (a common exporter quirk), but their float data practically always contains zero bytes.
bool looksAscii(const std::string& bytes) {
    size_t start = 0;
    while (start < bytes.size() &&
           (bytes[start] == ' ' || bytes[start] == '\t' || bytes[start] == '\r' || bytes[start] == '\n')) {
        ++start;
    }
    if (!equalsKeyword(std::string_view(bytes).substr(start, 5), "solid")) return false;
    return bytes.find('\0') == std::string::npos;
}

bool importStl(const std::string& path, MeshData& out, std::string& error) {
    out = MeshData{};
    out.sourcePath = path;
    std::string bytes;
    if (!readFile(path, bytes, error)) return false;
    bool ok = false;
    if (looksAscii(bytes)) {
        AsciiParser parser(path, bytes, out, error);
        ok = parser.parse();
    } else {
        ok = importBinary(path, bytes, out, error);
    }
    if (!ok) {
        out = MeshData{};
        return false;
    }
    return true;
}

class StlImporterPlugin final : public penumbra::plugin::IPlugin {
public:
    const char* name() const override { return "stl_importer"; }
    const char* version() const override { return "1.0.0"; }

    bool onLoad(penumbra::plugin::PluginContext& context) override {
        return context.registerImporter("stl", penumbra::plugin::MeshImporter(&importStl));
    }
};

}  // namespace

PENUMBRA_DEFINE_PLUGIN(StlImporterPlugin, "stl_importer")
