// PLY reader: ascii, binary_little_endian and binary_big_endian. The header is parsed with limits,
// every element count is checked against the bytes left in the file before anything is allocated,
// and the body is parsed straight from one in-memory copy of the file (std::from_chars, no streams).
#include <algorithm>
#include <bit>
#include <charconv>
#include <cstring>
#include <limits>
#include <string_view>

#include <fmt/format.h>

#include "engine/assets/mesh.h"
#include "engine/assets/mesh_internal.h"

namespace penumbra::assets {
namespace {

constexpr size_t kMaxHeaderBytes = 1u << 20;

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

enum class PlyType : uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

size_t typeSize(PlyType t) {
    switch (t) {
        case PlyType::Int8:
        case PlyType::UInt8:
            return 1;
        case PlyType::Int16:
        case PlyType::UInt16:
            return 2;
        case PlyType::Int32:
        case PlyType::UInt32:
        case PlyType::Float32:
            return 4;
        case PlyType::Float64:
            return 8;
    }
    return 1;
}

bool isIntegerType(PlyType t) { return t != PlyType::Float32 && t != PlyType::Float64; }

bool parseType(std::string_view s, PlyType& t) {
    struct Name {
        std::string_view name;
        PlyType type;
    };
    static constexpr Name kNames[] = {
        {"char", PlyType::Int8},       {"int8", PlyType::Int8},       {"uchar", PlyType::UInt8},
        {"uint8", PlyType::UInt8},     {"short", PlyType::Int16},     {"int16", PlyType::Int16},
        {"ushort", PlyType::UInt16},   {"uint16", PlyType::UInt16},   {"int", PlyType::Int32},
        {"int32", PlyType::Int32},     {"uint", PlyType::UInt32},     {"uint32", PlyType::UInt32},
        {"float", PlyType::Float32},   {"float32", PlyType::Float32}, {"double", PlyType::Float64},
        {"float64", PlyType::Float64},
    };
    for (const Name& n : kNames) {
        if (n.name == s) {
            t = n.type;
            return true;
        }
    }
    return false;
}

void integerRange(PlyType t, int64_t& lo, int64_t& hi) {
    switch (t) {
        case PlyType::Int8:
            lo = INT8_MIN, hi = INT8_MAX;
            return;
        case PlyType::UInt8:
            lo = 0, hi = UINT8_MAX;
            return;
        case PlyType::Int16:
            lo = INT16_MIN, hi = INT16_MAX;
            return;
        case PlyType::UInt16:
            lo = 0, hi = UINT16_MAX;
            return;
        case PlyType::Int32:
            lo = INT32_MIN, hi = INT32_MAX;
            return;
        case PlyType::UInt32:
            lo = 0, hi = UINT32_MAX;
            return;
        case PlyType::Float32:
        case PlyType::Float64:
            break;
    }
    lo = std::numeric_limits<int64_t>::min();
    hi = std::numeric_limits<int64_t>::max();
}

// Slots a vertex property can fill.
enum Target : int { kNone = -1, kX = 0, kY, kZ, kNx, kNy, kNz, kU, kV, kTargetCount };

struct PlyProperty {
    std::string name;
    bool isList = false;
    PlyType type = PlyType::Float32;     // scalar type, or list item type
    PlyType countType = PlyType::UInt8;  // list count type
    int target = kNone;                  // vertex slot, or 0 for the face index list
};

struct PlyElement {
    std::string name;
    uint64_t count = 0;
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    PlyFormat format = PlyFormat::Ascii;
    std::vector<PlyElement> elements;
    size_t dataOffset = 0;
};

std::vector<std::string_view> splitWords(std::string_view line) {
    std::vector<std::string_view> words;
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) {
            ++i;
        }
        const size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t') {
            ++i;
        }
        if (i > start) {
            words.push_back(line.substr(start, i - start));
        }
    }
    return words;
}

bool parseHeader(const std::string& path, const detail::FileBytes& bytes, PlyHeader& header,
                 std::string& error) {
    const std::string_view text(bytes.data(), std::min(bytes.size(), kMaxHeaderBytes));
    size_t pos = 0;
    int lineNo = 0;
    bool haveFormat = false;
    auto nextLine = [&](std::string_view& line) {
        const size_t nl = text.find('\n', pos);
        if (nl == std::string_view::npos) {
            return false;
        }
        line = text.substr(pos, nl - pos);
        if (!line.empty() && line.back() == '\r') {
            line.remove_suffix(1);
        }
        pos = nl + 1;
        ++lineNo;
        return true;
    };
    std::string_view line;
    if (!nextLine(line) || line != "ply") {
        if (bytes.size() >= 3 && std::memcmp(bytes.data(), "ply", 3) == 0 &&
            text.find('\n') == std::string_view::npos) {
            error = fmt::format("{}: truncated PLY header (no end_header)", path);
        } else {
            error = fmt::format("{}: not a PLY file (bad magic: the first line must be 'ply')", path);
        }
        return false;
    }
    for (;;) {
        if (!nextLine(line)) {
            if (bytes.size() > kMaxHeaderBytes) {
                error =
                    fmt::format("{}: PLY header longer than {} bytes (no end_header)", path, kMaxHeaderBytes);
            } else {
                error = fmt::format("{}: truncated PLY header (no end_header)", path);
            }
            return false;
        }
        const std::vector<std::string_view> w = splitWords(line);
        if (w.empty()) {
            continue;
        }
        if (w[0] == "comment" || w[0] == "obj_info") {
            continue;
        }
        if (w[0] == "end_header") {
            break;
        }
        if (w[0] == "format") {
            if (w.size() != 3) {
                error = fmt::format("{}: header line {}: malformed format line", path, lineNo);
                return false;
            }
            if (w[1] == "ascii") {
                header.format = PlyFormat::Ascii;
            } else if (w[1] == "binary_little_endian") {
                header.format = PlyFormat::BinaryLittleEndian;
            } else if (w[1] == "binary_big_endian") {
                header.format = PlyFormat::BinaryBigEndian;
            } else {
                error = fmt::format("{}: header line {}: unknown PLY format '{}'", path, lineNo, w[1]);
                return false;
            }
            if (w[2] != "1.0" && w[2] != "1") {
                error = fmt::format("{}: header line {}: unsupported PLY format version '{}'", path, lineNo,
                                    w[2]);
                return false;
            }
            haveFormat = true;
            continue;
        }
        if (w[0] == "element") {
            if (w.size() != 3) {
                error = fmt::format("{}: header line {}: malformed element line", path, lineNo);
                return false;
            }
            PlyElement el;
            el.name = std::string(w[1]);
            const char* b = w[2].data();
            const char* e = b + w[2].size();
            const auto res = std::from_chars(b, e, el.count);
            if (res.ec != std::errc() || res.ptr != e) {
                error = fmt::format("{}: header line {}: invalid count '{}' for element '{}'", path, lineNo,
                                    w[2], el.name);
                return false;
            }
            for (const PlyElement& other : header.elements) {
                if (other.name == el.name) {
                    error = fmt::format("{}: header line {}: duplicate element '{}'", path, lineNo, el.name);
                    return false;
                }
            }
            header.elements.push_back(std::move(el));
            continue;
        }
        if (w[0] == "property") {
            if (header.elements.empty()) {
                error = fmt::format("{}: header line {}: property before any element", path, lineNo);
                return false;
            }
            PlyProperty prop;
            if (w.size() == 5 && w[1] == "list") {
                prop.isList = true;
                if (!parseType(w[2], prop.countType) || !parseType(w[3], prop.type)) {
                    error =
                        fmt::format("{}: header line {}: unknown property type in '{}'", path, lineNo, line);
                    return false;
                }
                if (!isIntegerType(prop.countType)) {
                    error = fmt::format("{}: header line {}: list count type must be an integer type", path,
                                        lineNo);
                    return false;
                }
                prop.name = std::string(w[4]);
            } else if (w.size() == 3 && w[1] != "list") {
                if (!parseType(w[1], prop.type)) {
                    error = fmt::format("{}: header line {}: unknown property type '{}'", path, lineNo, w[1]);
                    return false;
                }
                prop.name = std::string(w[2]);
            } else {
                error = fmt::format("{}: header line {}: malformed property line '{}'", path, lineNo, line);
                return false;
            }
            PlyElement& el = header.elements.back();
            for (const PlyProperty& other : el.properties) {
                if (other.name == prop.name) {
                    error = fmt::format("{}: header line {}: duplicate property '{}' in element '{}'", path,
                                        lineNo, prop.name, el.name);
                    return false;
                }
            }
            el.properties.push_back(std::move(prop));
            continue;
        }
        error = fmt::format("{}: header line {}: unknown header keyword '{}'", path, lineNo, w[0]);
        return false;
    }
    if (!haveFormat) {
        error = fmt::format("{}: PLY header has no format line", path);
        return false;
    }
    header.dataOffset = pos;
    return true;
}

enum class Status { Ok, Eof, Invalid, Range };

bool isSpace(char c) { return c == ' ' || (c >= '\t' && c <= '\r'); }

// Reads whitespace-separated numbers straight from the buffer: numbers are parsed in place and
// must end at whitespace or at the end of the file.
struct AsciiCursor {
    const char* p;
    const char* end;

    static constexpr size_t kMinScalarBytes = 2;  // one character and a separator

    bool skipSpace() {
        while (p < end && isSpace(*p)) {
            ++p;
        }
        return p < end;
    }

    bool atTokenEnd(const char* q) const { return q == end || isSpace(*q); }

    template <typename T>
    Status readFloat(T& value) {
        if (!skipSpace()) {
            return Status::Eof;
        }
        const char* b = p;
        if (*b == '+') {
            ++b;
        }
        const auto r = std::from_chars(b, end, value);
        if (r.ec == std::errc::invalid_argument || !atTokenEnd(r.ptr)) {
            return Status::Invalid;
        }
        p = r.ptr;
        return r.ec == std::errc::result_out_of_range ? Status::Range : Status::Ok;
    }

    Status readReal(PlyType t, double& value) {
        if (t == PlyType::Float32) {
            float f = 0.0f;
            const Status s = readFloat(f);
            value = f;
            return s;
        }
        if (t == PlyType::Float64) {
            return readFloat(value);
        }
        int64_t i = 0;
        const Status s = readInt(t, i);
        value = double(i);
        return s;
    }

    // Integer types only (list counts and face indices are integer-typed, checked in the header).
    Status readInt(PlyType t, int64_t& value) {
        if (!skipSpace()) {
            return Status::Eof;
        }
        bool negative = false;
        if (*p == '-' || *p == '+') {
            negative = *p == '-';
            ++p;
        }
        const char* digits = p;
        uint64_t v = 0;
        while (p < end && *p >= '0' && *p <= '9') {
            if (p - digits >= 18) {
                return Status::Range;  // beyond every PLY integer type
            }
            v = v * 10 + uint64_t(*p - '0');
            ++p;
        }
        if (p == digits || !atTokenEnd(p)) {
            return Status::Invalid;
        }
        value = negative ? -int64_t(v) : int64_t(v);
        int64_t lo, hi;
        integerRange(t, lo, hi);
        return (value < lo || value > hi) ? Status::Range : Status::Ok;
    }

    Status skip(PlyType) {
        if (!skipSpace()) {
            return Status::Eof;
        }
        while (p < end && !isSpace(*p)) {
            ++p;
        }
        return Status::Ok;
    }

    Status skipItems(PlyType t, uint64_t n) {
        for (uint64_t i = 0; i < n; ++i) {
            if (skip(t) != Status::Ok) {
                return Status::Eof;
            }
        }
        return Status::Ok;
    }

    // Upper bound on how many items can still follow (each needs at least one character).
    uint64_t maxItemsLeft() const { return uint64_t(end - p) / kMinScalarBytes + 1; }
};

template <bool Swap>
struct BinaryCursor {
    const char* p;
    const char* end;

    template <typename T>
    T load() {
        T v;
        if constexpr (Swap && sizeof(T) > 1) {
            char tmp[sizeof(T)];
            for (size_t i = 0; i < sizeof(T); ++i) {
                tmp[i] = p[sizeof(T) - 1 - i];
            }
            std::memcpy(&v, tmp, sizeof(T));
        } else {
            std::memcpy(&v, p, sizeof(T));
        }
        p += sizeof(T);
        return v;
    }

    Status readReal(PlyType t, double& value) {
        if (size_t(end - p) < typeSize(t)) {
            return Status::Eof;
        }
        switch (t) {
            case PlyType::Int8:
                value = load<int8_t>();
                break;
            case PlyType::UInt8:
                value = load<uint8_t>();
                break;
            case PlyType::Int16:
                value = load<int16_t>();
                break;
            case PlyType::UInt16:
                value = load<uint16_t>();
                break;
            case PlyType::Int32:
                value = load<int32_t>();
                break;
            case PlyType::UInt32:
                value = load<uint32_t>();
                break;
            case PlyType::Float32:
                value = load<float>();
                break;
            case PlyType::Float64:
                value = load<double>();
                break;
        }
        return Status::Ok;
    }

    // Integer types only (list counts and face indices are integer-typed, checked in the header).
    Status readInt(PlyType t, int64_t& value) {
        if (size_t(end - p) < typeSize(t)) {
            return Status::Eof;
        }
        switch (t) {
            case PlyType::Int8:
                value = load<int8_t>();
                break;
            case PlyType::UInt8:
                value = load<uint8_t>();
                break;
            case PlyType::Int16:
                value = load<int16_t>();
                break;
            case PlyType::UInt16:
                value = load<uint16_t>();
                break;
            case PlyType::Int32:
                value = load<int32_t>();
                break;
            case PlyType::UInt32:
                value = load<uint32_t>();
                break;
            case PlyType::Float32:
            case PlyType::Float64:
                return Status::Invalid;
        }
        return Status::Ok;
    }

    Status skip(PlyType t) {
        if (size_t(end - p) < typeSize(t)) {
            return Status::Eof;
        }
        p += typeSize(t);
        return Status::Ok;
    }

    Status skipItems(PlyType t, uint64_t n) {
        if (n > uint64_t(end - p) / typeSize(t)) {
            return Status::Eof;
        }
        p += n * typeSize(t);
        return Status::Ok;
    }

    uint64_t maxItemsLeft(PlyType t) const { return uint64_t(end - p) / typeSize(t); }
};

class PlyParser {
public:
    PlyParser(const std::string& path, PlyHeader& header, const MeshLoadLimits& limits, MeshData& out)
        : m_path(path), m_header(header), m_limits(limits), m_out(out) {}

    // Assigns targets, checks counts against the remaining bytes, allocates.
    bool prepare(size_t fileSize, std::string& error) {
        for (size_t ei = 0; ei < m_header.elements.size(); ++ei) {
            const PlyElement& el = m_header.elements[ei];
            if (el.name == "vertex") {
                m_vertexElement = int(ei);
            } else if (el.name == "face") {
                m_faceElement = int(ei);
            }
        }
        if (m_vertexElement < 0) {
            error = fmt::format("{}: PLY header has no 'vertex' element", m_path);
            return false;
        }
        m_vertexCount = m_header.elements[size_t(m_vertexElement)].count;
        if (!assignVertexTargets(error) || !assignFaceTarget(error)) {
            return false;
        }

        // Every declared count must fit in the bytes that follow the header.
        const bool ascii = m_header.format == PlyFormat::Ascii;
        uint64_t remaining = fileSize - m_header.dataOffset + (ascii ? 1 : 0);
        for (const PlyElement& el : m_header.elements) {
            uint64_t minRecord = 0;
            for (const PlyProperty& p : el.properties) {
                minRecord += ascii ? AsciiCursor::kMinScalarBytes : typeSize(p.isList ? p.countType : p.type);
            }
            if (minRecord == 0) {
                continue;
            }
            if (el.count > remaining / minRecord) {
                error = fmt::format(
                    "{}: element '{}' declares {} records but only {} bytes of data remain (at least {} "
                    "bytes "
                    "per record): count larger than the file or truncated file",
                    m_path, el.name, el.count, fileSize - m_header.dataOffset, minRecord);
                return false;
            }
            remaining -= el.count * minRecord;
        }
        if (m_vertexCount > m_limits.maxVertices) {
            error = fmt::format("{}: element 'vertex' count {} exceeds the vertex limit {}", m_path,
                                m_vertexCount, m_limits.maxVertices);
            return false;
        }

        m_out.positions.reserve(size_t(m_vertexCount));
        if (m_hasNormals) {
            m_out.normals.reserve(size_t(m_vertexCount));
        }
        if (m_hasUvs) {
            m_out.uvs.reserve(size_t(m_vertexCount));
        }
        if (m_faceElement >= 0) {
            const PlyElement& faces = m_header.elements[size_t(m_faceElement)];
            const PlyProperty& list = faces.properties[size_t(m_faceListProperty)];
            const uint64_t triangleBytes = ascii ? 8 : typeSize(list.countType) + 3 * typeSize(list.type);
            const uint64_t bound = std::min<uint64_t>(
                {faces.count, m_limits.maxTriangles, (fileSize - m_header.dataOffset) / triangleBytes + 1});
            m_out.indices.reserve(size_t(bound) * 3);
            detail::adviseHugePages(m_out.indices.data(), m_out.indices.capacity() * sizeof(uint32_t));
        }
        detail::adviseHugePages(m_out.positions.data(), m_out.positions.capacity() * sizeof(glm::vec3));
        return true;
    }

    template <typename Cursor>
    bool parseBody(Cursor& cur, std::string& error) {
        for (size_t ei = 0; ei < m_header.elements.size(); ++ei) {
            const PlyElement& el = m_header.elements[ei];
            if (el.properties.empty()) {
                continue;
            }
            bool ok = true;
            if (int(ei) == m_vertexElement) {
                ok = parseVertices(cur, el, error);
            } else if (int(ei) == m_faceElement) {
                ok = parseFaces(cur, el, error);
            } else {
                ok = skipElement(cur, el, error);
            }
            if (!ok) {
                return false;
            }
        }
        return true;
    }

private:
    bool assignVertexTargets(std::string& error) {
        PlyElement& el = m_header.elements[size_t(m_vertexElement)];
        int found[kTargetCount];
        std::fill(std::begin(found), std::end(found), -1);
        struct Alias {
            std::string_view name;
            int target;
        };
        static constexpr Alias kAliases[] = {
            {"x", kX},         {"y", kY},         {"z", kZ},         {"nx", kNx},       {"ny", kNy},
            {"nz", kNz},       {"u", kU},         {"v", kV},         {"s", kU},         {"t", kV},
            {"texture_u", kU}, {"texture_v", kV}, {"texture_s", kU}, {"texture_t", kV},
        };
        for (size_t pi = 0; pi < el.properties.size(); ++pi) {
            PlyProperty& p = el.properties[pi];
            for (const Alias& a : kAliases) {
                if (p.name == a.name && found[a.target] < 0) {
                    if (p.isList) {
                        if (a.target <= kZ) {
                            error =
                                fmt::format("{}: element 'vertex' property '{}' is a list, expected a scalar",
                                            m_path, p.name);
                            return false;
                        }
                        break;
                    }
                    found[a.target] = int(pi);
                    break;
                }
            }
        }
        for (int t = kX; t <= kZ; ++t) {
            if (found[t] < 0) {
                error = fmt::format("{}: element 'vertex' has no property '{}'", m_path, "xyz"[t]);
                return false;
            }
        }
        m_hasNormals = found[kNx] >= 0 && found[kNy] >= 0 && found[kNz] >= 0;
        m_hasUvs = found[kU] >= 0 && found[kV] >= 0;
        for (int t = 0; t < kTargetCount; ++t) {
            const bool used = t <= kZ || (t <= kNz && m_hasNormals) || (t >= kU && m_hasUvs);
            if (found[t] >= 0 && used) {
                el.properties[size_t(found[t])].target = t;
            }
        }
        return true;
    }

    bool assignFaceTarget(std::string& error) {
        if (m_faceElement < 0) {
            return true;
        }
        PlyElement& el = m_header.elements[size_t(m_faceElement)];
        for (size_t pi = 0; pi < el.properties.size(); ++pi) {
            PlyProperty& p = el.properties[pi];
            if (p.name == "vertex_indices" || p.name == "vertex_index") {
                if (!p.isList) {
                    error = fmt::format("{}: element 'face' property '{}' must be a list", m_path, p.name);
                    return false;
                }
                if (!isIntegerType(p.type)) {
                    error = fmt::format("{}: element 'face' property '{}' must have an integer item type",
                                        m_path, p.name);
                    return false;
                }
                p.target = 0;
                m_faceListProperty = int(pi);
                return true;
            }
        }
        error = fmt::format("{}: element 'face' has no 'vertex_indices' list", m_path);
        return false;
    }

    std::string statusText(Status s) const {
        switch (s) {
            case Status::Eof:
                return "unexpected end of file (truncated file)";
            case Status::Invalid:
                return "invalid number";
            case Status::Range:
                return "value out of range for its type (or not a finite number)";
            case Status::Ok:
                break;
        }
        return "ok";
    }

    std::string where(const PlyElement& el, uint64_t record, const PlyProperty& p) const {
        return fmt::format("{}: element '{}' #{} property '{}'", m_path, el.name, record, p.name);
    }

    template <typename Cursor>
    bool readListCount(Cursor& cur, const PlyElement& el, uint64_t r, const PlyProperty& p, uint64_t& n,
                       std::string& error) {
        int64_t count = 0;
        const Status s = cur.readInt(p.countType, count);
        if (s != Status::Ok) {
            error = fmt::format("{}: list count: {}", where(el, r, p), statusText(s));
            return false;
        }
        if (count < 0) {
            error = fmt::format("{}: negative list count {}", where(el, r, p), count);
            return false;
        }
        uint64_t left;
        if constexpr (std::is_same_v<Cursor, AsciiCursor>) {
            left = cur.maxItemsLeft();
        } else {
            left = cur.maxItemsLeft(p.type);
        }
        if (uint64_t(count) > left) {
            error = fmt::format(
                "{}: list count {} is larger than the rest of the file (truncated file or bad count)",
                where(el, r, p), count);
            return false;
        }
        n = uint64_t(count);
        return true;
    }

    template <typename Cursor>
    bool skipProperty(Cursor& cur, const PlyElement& el, uint64_t r, const PlyProperty& p,
                      std::string& error) {
        if (!p.isList) {
            const Status s = cur.skip(p.type);
            if (s != Status::Ok) {
                error = fmt::format("{}: {}", where(el, r, p), statusText(s));
                return false;
            }
            return true;
        }
        uint64_t n = 0;
        if (!readListCount(cur, el, r, p, n, error)) {
            return false;
        }
        const Status s = cur.skipItems(p.type, n);
        if (s != Status::Ok) {
            error = fmt::format("{}: {}", where(el, r, p), statusText(s));
            return false;
        }
        return true;
    }

    template <typename Cursor>
    bool skipElement(Cursor& cur, const PlyElement& el, std::string& error) {
        for (uint64_t r = 0; r < el.count; ++r) {
            for (const PlyProperty& p : el.properties) {
                if (!skipProperty(cur, el, r, p, error)) {
                    return false;
                }
            }
        }
        return true;
    }

    template <typename Cursor>
    bool parseVertices(Cursor& cur, const PlyElement& el, std::string& error) {
        double v[kTargetCount] = {};
        for (uint64_t r = 0; r < el.count; ++r) {
            for (const PlyProperty& p : el.properties) {
                if (p.target < 0) {
                    if (!skipProperty(cur, el, r, p, error)) {
                        return false;
                    }
                    continue;
                }
                const Status s = cur.readReal(p.type, v[p.target]);
                if (s != Status::Ok) {
                    error = fmt::format("{}: {}", where(el, r, p), statusText(s));
                    return false;
                }
            }
            m_out.positions.emplace_back(float(v[kX]), float(v[kY]), float(v[kZ]));
            if (m_hasNormals) {
                m_out.normals.emplace_back(float(v[kNx]), float(v[kNy]), float(v[kNz]));
            }
            if (m_hasUvs) {
                m_out.uvs.emplace_back(float(v[kU]), float(v[kV]));
            }
        }
        return true;
    }

    template <typename Cursor>
    bool parseFaces(Cursor& cur, const PlyElement& el, std::string& error) {
        std::vector<uint32_t> polygon;
        for (uint64_t r = 0; r < el.count; ++r) {
            for (const PlyProperty& p : el.properties) {
                if (p.target < 0) {
                    if (!skipProperty(cur, el, r, p, error)) {
                        return false;
                    }
                    continue;
                }
                uint64_t n = 0;
                if (!readListCount(cur, el, r, p, n, error)) {
                    return false;
                }
                polygon.resize(size_t(n));
                for (uint64_t k = 0; k < n; ++k) {
                    int64_t idx = 0;
                    const Status s = cur.readInt(p.type, idx);
                    if (s != Status::Ok) {
                        error = fmt::format("{}: item {}: {}", where(el, r, p), k, statusText(s));
                        return false;
                    }
                    if (idx < 0 || uint64_t(idx) >= m_vertexCount) {
                        error = fmt::format("{}: vertex index {} out of range (vertex count {})",
                                            where(el, r, p), idx, m_vertexCount);
                        return false;
                    }
                    polygon[size_t(k)] = uint32_t(idx);
                }
                if (n < 3) {
                    continue;  // points and edges carry no surface
                }
                if (m_out.indices.size() / 3 + (n - 2) > m_limits.maxTriangles) {
                    error = fmt::format("{}: element 'face' produces more than {} triangles (limit)", m_path,
                                        m_limits.maxTriangles);
                    return false;
                }
                for (uint64_t k = 1; k + 1 < n; ++k) {
                    m_out.indices.push_back(polygon[0]);
                    m_out.indices.push_back(polygon[size_t(k)]);
                    m_out.indices.push_back(polygon[size_t(k + 1)]);
                }
            }
        }
        return true;
    }

    const std::string& m_path;
    PlyHeader& m_header;
    const MeshLoadLimits& m_limits;
    MeshData& m_out;
    int m_vertexElement = -1;
    int m_faceElement = -1;
    int m_faceListProperty = -1;
    uint64_t m_vertexCount = 0;
    bool m_hasNormals = false;
    bool m_hasUvs = false;
};

bool loadPlyImpl(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits) {
    detail::FileBytes bytes;
    if (!detail::readWholeFile(path, limits.maxFileBytes, bytes, error)) {
        return false;
    }
    PlyHeader header;
    if (!parseHeader(path, bytes, header, error)) {
        return false;
    }
    PlyParser parser(path, header, limits, out);
    if (!parser.prepare(bytes.size(), error)) {
        return false;
    }
    const char* begin = bytes.data() + header.dataOffset;
    const char* end = bytes.data() + bytes.size();
    bool ok = false;
    const bool nativeLittle = std::endian::native == std::endian::little;
    switch (header.format) {
        case PlyFormat::Ascii: {
            AsciiCursor cur{begin, end};
            ok = parser.parseBody(cur, error);
            break;
        }
        case PlyFormat::BinaryLittleEndian:
        case PlyFormat::BinaryBigEndian: {
            const bool swap = (header.format == PlyFormat::BinaryLittleEndian) != nativeLittle;
            if (swap) {
                BinaryCursor<true> cur{begin, end};
                ok = parser.parseBody(cur, error);
            } else {
                BinaryCursor<false> cur{begin, end};
                ok = parser.parseBody(cur, error);
            }
            break;
        }
    }
    if (!ok) {
        return false;
    }
    return detail::validateMesh(out, limits, error);
}

}  // namespace

bool loadPly(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits) {
    out = MeshData{};
    out.sourcePath = path;
    bool ok = false;
    try {
        ok = loadPlyImpl(path, out, error, limits);
    } catch (const std::exception& e) {
        error = fmt::format("{}: cannot load PLY: {}", path, e.what());
        ok = false;
    }
    if (!ok) {
        out = MeshData{};
        out.sourcePath = path;
    }
    return ok;
}

}  // namespace penumbra::assets
