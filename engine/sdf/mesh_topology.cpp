#include "engine/sdf/mesh_topology.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <mutex>
#include <new>
#include <stdexcept>
#include <system_error>
#include <thread>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "engine/sdf/huge_pages.h"

namespace penumbra::sdf {

namespace {

constexpr uint32_t kNone = UINT32_MAX;

// Zero-area test: |ab x ac| <= kDegenerateTolerance * (longest edge)^2. The cross product of exact
// float differences is accurate to ~1e-16 relative, so this only catches (numerically) collinear
// corners; removing such a sliver moves the surface by at most 1e-12 of its length.
constexpr double kDegenerateTolerance = 1e-12;

uint32_t floatBits(float f) {
    if (f == 0.0f) f = 0.0f;  // -0 and +0 are the same position
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
}

uint64_t hashPosition(const glm::vec3& p) {
    uint64_t h = (uint64_t(floatBits(p.x)) << 32 | floatBits(p.y)) ^
                 (uint64_t(floatBits(p.z)) * 0x9E3779B97F4A7C15ull);
    h ^= h >> 33;  // 64-bit finaliser (MurmurHash3 constants)
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h;
}

bool samePosition(const glm::vec3& a, const glm::vec3& b) {
    return floatBits(a.x) == floatBits(b.x) && floatBits(a.y) == floatBits(b.y) &&
           floatBits(a.z) == floatBits(b.z);
}

// Sorts a small bucket of (key, payload) pairs by key (insertion sort: buckets hold a few entries).
template <typename T, typename Less>
void sortSmall(T* first, T* last, Less less) {
    if (last - first > 32) {
        std::sort(first, last, less);
        return;
    }
    for (T* i = first + 1; i < last; ++i) {
        T v = *i;
        T* j = i;
        while (j > first && less(v, *(j - 1))) {
            *j = *(j - 1);
            --j;
        }
        *j = v;
    }
}

// Triangles around each vertex as compressed rows, in increasing triangle order; each entry also
// holds the triangle's next and previous corner after the vertex, so scans of a row read no
// triangle data.
struct RingEntry {
    uint32_t triangle, next, prev;
};

uint32_t partsFor(uint32_t threads, size_t work) {
    if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
    return static_cast<uint32_t>(std::clamp<size_t>(work / 65536, 1, threads));
}

// Runs fn(part, begin, end) over `parts` contiguous ranges of [0, n), part 0 on the calling thread.
template <typename Fn>
void forParts(uint32_t parts, size_t n, Fn&& fn) {
    std::exception_ptr error;  // first exception of any part, rethrown after the join
    std::mutex mutex;
    auto run = [&](uint32_t part, size_t b, size_t e) {
        try {
            fn(part, b, e);
        } catch (...) {
            std::lock_guard lock(mutex);
            if (!error) error = std::current_exception();
        }
    };
    std::vector<std::thread> pool;
    for (uint32_t part = 1; part < parts; ++part) {
        const size_t b = n * part / parts, e = n * (part + 1) / parts;
        try {
            pool.emplace_back(run, part, b, e);
        } catch (const std::system_error&) {
            run(part, b, e);
        }
    }
    run(0u, size_t(0), n / parts);
    for (std::thread& t : pool) t.join();
    if (error) std::rethrow_exception(error);
}

}  // namespace

bool cleanMesh(const assets::MeshData& mesh, CleanMesh& out, std::string& error) {
    return cleanMesh(mesh, out, error, 1);
}

namespace {

// The input checks: whole triangles, not empty, vertex ids that fit, finite coordinates and
// indices in range.
bool validateMesh(const assets::MeshData& mesh, std::string& error) {
    const size_t vertexCount = mesh.positions.size();
    if (mesh.indices.size() % 3 != 0) {
        error = fmt::format("mesh index count {} is not a multiple of 3", mesh.indices.size());
        return false;
    }
    if (vertexCount == 0 || mesh.indices.empty()) {
        error =
            fmt::format("mesh is empty ({} vertices, {} triangles)", vertexCount, mesh.indices.size() / 3);
        return false;
    }
    if (vertexCount >= kNone) {
        error = fmt::format("mesh has too many vertices ({})", vertexCount);
        return false;
    }
    for (size_t v = 0; v < vertexCount; ++v) {
        const glm::vec3& p = mesh.positions[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            error = fmt::format("vertex {} has a non-finite coordinate ({}, {}, {})", v, p.x, p.y, p.z);
            return false;
        }
    }
    for (size_t i = 0; i < mesh.indices.size(); ++i) {
        if (mesh.indices[i] >= vertexCount) {
            error = fmt::format("triangle {} references vertex {} but the mesh has {} vertices", i / 3,
                                mesh.indices[i], vertexCount);
            return false;
        }
    }
    return true;
}

struct MergedVertices {
    std::vector<uint32_t> remap;         // input vertex -> unique id (kNone: not referenced)
    std::vector<uint32_t> uniqueSource;  // unique id -> first input vertex
    size_t referenced = 0;               // input vertices referenced by a triangle
};

// Merges exactly coincident vertices among those referenced by a triangle.
MergedVertices mergeCoincidentVertices(const assets::MeshData& mesh) {
    const size_t vertexCount = mesh.positions.size();
    MergedVertices merged;
    std::vector<uint32_t>& remap = merged.remap;
    std::vector<uint32_t>& uniqueSource = merged.uniqueSource;
    resizeHuge(remap, vertexCount, kNone);
    for (uint32_t index : mesh.indices) remap[index] = 0;
    size_t referenced = 0;
    for (uint32_t r : remap) referenced += r == 0 ? 1 : 0;
    merged.referenced = referenced;
    // Open addressing; an entry holds the upper hash bits above the unique id, so positions are
    // only compared when those agree.
    size_t tableSize = 16;
    while (tableSize < referenced * 2) tableSize *= 2;
    constexpr uint64_t kEmpty = UINT64_MAX;
    std::vector<uint64_t> table;
    resizeHuge(table, tableSize, kEmpty);
    reserveHuge(uniqueSource, referenced);
    for (size_t v = 0; v < vertexCount; ++v) {
        if (remap[v] == kNone) continue;
        const glm::vec3& p = mesh.positions[v];
        const uint64_t hash = hashPosition(p);
        const uint64_t tag = hash >> 32;
        size_t slot = hash & (tableSize - 1);
        for (;;) {
            const uint64_t entry = table[slot];
            if (entry == kEmpty) {
                const uint32_t id = static_cast<uint32_t>(uniqueSource.size());
                table[slot] = tag << 32 | id;
                remap[v] = id;
                uniqueSource.push_back(static_cast<uint32_t>(v));
                break;
            }
            const uint32_t u = static_cast<uint32_t>(entry);
            if ((entry >> 32) == tag && samePosition(mesh.positions[uniqueSource[u]], p)) {
                remap[v] = u;
                break;
            }
            slot = (slot + 1) & (tableSize - 1);
        }
    }
    return merged;
}

// The triangles over unique ids, in input order, without the degenerate ones (a repeated (merged)
// vertex or zero area), counted in diag.degenerateTrianglesRemoved.
std::vector<glm::uvec3> dropDegenerateTriangles(const assets::MeshData& mesh, const MergedVertices& merged,
                                                uint32_t parts, MeshDiagnostics& diag) {
    const std::vector<uint32_t>& remap = merged.remap;
    const std::vector<uint32_t>& uniqueSource = merged.uniqueSource;
    const size_t triangleCount = mesh.indices.size() / 3;
    std::vector<uint8_t> keep;
    resizeHuge(keep, triangleCount, uint8_t(0));
    std::vector<size_t> kept(parts + 1, 0);
    std::vector<uint64_t> degenerate(parts, 0);
    forParts(parts, triangleCount, [&](uint32_t part, size_t begin, size_t end) {
        size_t n = 0;
        for (size_t t = begin; t < end; ++t) {
            const glm::uvec3 tri(remap[mesh.indices[3 * t]], remap[mesh.indices[3 * t + 1]],
                                 remap[mesh.indices[3 * t + 2]]);
            bool ok = tri.x != tri.y && tri.y != tri.z && tri.z != tri.x;
            if (ok) {
                const glm::dvec3 a(mesh.positions[uniqueSource[tri.x]]);
                const glm::dvec3 e1 = glm::dvec3(mesh.positions[uniqueSource[tri.y]]) - a;
                const glm::dvec3 e2 = glm::dvec3(mesh.positions[uniqueSource[tri.z]]) - a;
                const glm::dvec3 e3 = e2 - e1;
                const double longest2 = std::max({glm::dot(e1, e1), glm::dot(e2, e2), glm::dot(e3, e3)});
                const glm::dvec3 c = glm::cross(e1, e2);
                ok = std::sqrt(glm::dot(c, c)) > kDegenerateTolerance * longest2;
            }
            keep[t] = ok ? 1 : 0;
            n += ok ? 1 : 0;
        }
        kept[part + 1] = n;
        degenerate[part] = (end - begin) - n;
    });
    for (uint32_t part = 0; part < parts; ++part) {
        kept[part + 1] += kept[part];
        diag.degenerateTrianglesRemoved += degenerate[part];
    }
    std::vector<glm::uvec3> tris;
    resizeHuge(tris, kept[parts]);
    forParts(parts, triangleCount, [&](uint32_t part, size_t begin, size_t end) {
        size_t w = kept[part];
        for (size_t t = begin; t < end; ++t) {
            if (keep[t]) {
                tris[w++] = glm::uvec3(remap[mesh.indices[3 * t]], remap[mesh.indices[3 * t + 1]],
                                       remap[mesh.indices[3 * t + 2]]);
            }
        }
    });
    return tris;
}

struct Rings {
    std::vector<uint32_t> start;  // row of vertex v: entries[start[v] .. start[v + 1])
    std::vector<RingEntry> entries;
};

// Rings (rows of triangles around each vertex, with the corners after the vertex). Each part
// owns a range of vertices and scans all triangles for their corners.
Rings buildRings(const std::vector<glm::uvec3>& tris, size_t uniqueCount, uint32_t parts) {
    Rings rings;
    std::vector<uint32_t>& ringStart = rings.start;
    resizeHuge(ringStart, uniqueCount + 1, 0u);
    forParts(parts, uniqueCount, [&](uint32_t, size_t vb, size_t ve) {
        for (const glm::uvec3& t : tris) {
            for (int k = 0; k < 3; ++k) {
                if (t[k] >= vb && t[k] < ve) ++ringStart[t[k] + 1];
            }
        }
    });
    for (size_t v = 0; v < uniqueCount; ++v) ringStart[v + 1] += ringStart[v];
    std::vector<RingEntry>& ring = rings.entries;
    resizeHuge(ring, tris.size() * 3);
    forParts(parts, uniqueCount, [&](uint32_t, size_t vb, size_t ve) {
        std::vector<uint32_t> fill(ringStart.begin() + vb, ringStart.begin() + ve);
        for (size_t t = 0; t < tris.size(); ++t) {
            const glm::uvec3& tri = tris[t];
            const uint32_t id = static_cast<uint32_t>(t);
            for (int k = 0; k < 3; ++k) {
                if (tri[k] >= vb && tri[k] < ve)
                    ring[fill[tri[k] - vb]++] = RingEntry{id, tri[(k + 1) % 3], tri[(k + 2) % 3]};
            }
        }
    });
    return rings;
}

// Per part (vertex range) of the topology analysis.
struct PartCounts {
    uint64_t duplicates = 0, opposite = 0, boundary = 0, nonManifold = 0, inconsistent = 0;
    std::vector<std::pair<uint32_t, int>> netChanges;  // (first of a group, +1 / -1)
};

// Duplicate triangles (same vertex set, either orientation): keep the first. Found in the row of
// each triangle's smallest vertex, where its other two corners are (next, prev): equal pairs are
// equal orientations, swapped pairs flipped ones. A triangle is decided in exactly one row, so
// parts never write the same flag.
void findDuplicateTriangles(const Rings& rings, size_t uniqueCount, uint32_t parts,
                            std::vector<uint8_t>& duplicate, std::vector<PartCounts>& counts) {
    forParts(parts, uniqueCount, [&](uint32_t part, size_t vb, size_t ve) {
        PartCounts& c = counts[part];
        for (size_t v = vb; v < ve; ++v) {
            const RingEntry* row = rings.entries.data() + rings.start[v];
            const uint32_t n = rings.start[v + 1] - rings.start[v];
            for (uint32_t i = 0; i < n; ++i) {
                const RingEntry& e = row[i];
                if (e.next < v || e.prev < v) continue;  // v is not this triangle's smallest corner
                for (uint32_t j = 0; j < i; ++j) {
                    const RingEntry& f = row[j];
                    if (f.next < v || f.prev < v || duplicate[f.triangle]) continue;
                    const bool same = f.next == e.next && f.prev == e.prev;
                    if (!same && !(f.next == e.prev && f.prev == e.next)) continue;
                    duplicate[e.triangle] = 1;
                    ++c.duplicates;
                    if (!same) ++c.opposite;
                    c.netChanges.emplace_back(f.triangle, same ? 1 : -1);
                    break;
                }
            }
        }
    });
}

// Edge uses (all duplicates known): for each vertex v, the edges to larger neighbours w with their
// direction; one use -> boundary, more than two -> non-manifold, two in the same direction ->
// inconsistently oriented.
void countEdgeUses(const Rings& rings, size_t uniqueCount, uint32_t parts,
                   const std::vector<uint8_t>& duplicate, std::vector<PartCounts>& counts) {
    forParts(parts, uniqueCount, [&](uint32_t part, size_t vb, size_t ve) {
        PartCounts& c = counts[part];
        struct Use {
            uint32_t other;
            bool outgoing;
        };
        std::vector<Use> uses;
        for (size_t v = vb; v < ve; ++v) {
            uses.clear();
            for (uint32_t r = rings.start[v]; r < rings.start[v + 1]; ++r) {
                const RingEntry& e = rings.entries[r];
                if (duplicate[e.triangle]) continue;
                if (e.next > v) uses.push_back(Use{e.next, true});
                if (e.prev > v) uses.push_back(Use{e.prev, false});
            }
            sortSmall(uses.data(), uses.data() + uses.size(),
                      [](const Use& a, const Use& b) { return a.other < b.other; });
            for (size_t i = 0; i < uses.size();) {
                size_t j = i + 1;
                while (j < uses.size() && uses[j].other == uses[i].other) ++j;
                const size_t n = j - i;
                if (n == 1) ++c.boundary;
                if (n > 2) ++c.nonManifold;
                if (n == 2 && uses[i].outgoing == uses[i + 1].outgoing) ++c.inconsistent;
                i = j;
            }
        }
    });
}

// Sums the part counts into diag; returns per first triangle of a duplicate group its net copies
// (empty: no duplicates).
std::vector<int32_t> sumPartCounts(const std::vector<PartCounts>& counts, size_t triangleCount,
                                   MeshDiagnostics& diag) {
    std::vector<int32_t> net;
    for (const PartCounts& c : counts) {
        diag.duplicateTrianglesRemoved += c.duplicates;
        diag.oppositeDuplicateTriangles += c.opposite;
        diag.boundaryEdges += c.boundary;
        diag.nonManifoldEdges += c.nonManifold;
        diag.inconsistentEdges += c.inconsistent;
        if (!c.netChanges.empty() && net.empty()) net.assign(triangleCount, 1);
        for (const auto& [first, change] : c.netChanges) net[first] += change;
    }
    diag.closedManifold = diag.boundaryEdges == 0 && diag.nonManifoldEdges == 0;
    return net;
}

struct VertexNumbering {
    std::vector<uint32_t> compact;           // unique id -> output vertex (kNone: unused)
    std::vector<uint32_t> newStart;          // output ring rows (used + 1 entries)
    uint32_t used = 0;                       // vertices left
    glm::dvec3 lo{INFINITY}, hi{-INFINITY};  // their bounds
};

// Numbers the used vertices (non-empty rows once duplicates are dropped) in input order, with the
// starts of their compacted rows and their bounds: per part counts, then offsets.
VertexNumbering numberUsedVertices(const assets::MeshData& mesh, const std::vector<uint32_t>& uniqueSource,
                                   const Rings& rings, const std::vector<uint8_t>& duplicate,
                                   uint32_t parts) {
    const size_t uniqueCount = uniqueSource.size();
    VertexNumbering numbering;
    resizeHuge(numbering.compact, uniqueCount, kNone);
    std::vector<uint32_t> rowSize;  // per unique vertex: triangles kept in its row
    resizeHuge(rowSize, uniqueCount, 0u);
    forParts(parts, uniqueCount, [&](uint32_t, size_t vb, size_t ve) {
        for (size_t u = vb; u < ve; ++u) {
            uint32_t n = 0;
            for (uint32_t r = rings.start[u]; r < rings.start[u + 1]; ++r)
                n += duplicate[rings.entries[r].triangle] ? 0 : 1;
            rowSize[u] = n;
        }
    });
    std::vector<uint32_t> partUsed(parts + 1, 0), partRows(parts + 1, 0);
    std::vector<glm::dvec3> partLo(parts, glm::dvec3(INFINITY)), partHi(parts, glm::dvec3(-INFINITY));
    forParts(parts, uniqueCount, [&](uint32_t part, size_t vb, size_t ve) {
        uint32_t n = 0, rows = 0;
        for (size_t u = vb; u < ve; ++u) {
            if (rowSize[u] == 0) continue;
            ++n;
            rows += rowSize[u];
            const glm::dvec3 p(mesh.positions[uniqueSource[u]]);
            partLo[part] = glm::min(partLo[part], p);
            partHi[part] = glm::max(partHi[part], p);
        }
        partUsed[part + 1] = n;
        partRows[part + 1] = rows;
    });
    for (uint32_t part = 0; part < parts; ++part) {
        partUsed[part + 1] += partUsed[part];
        partRows[part + 1] += partRows[part];
        numbering.lo = glm::min(numbering.lo, partLo[part]);
        numbering.hi = glm::max(numbering.hi, partHi[part]);
    }
    numbering.used = partUsed[parts];
    resizeHuge(numbering.newStart, size_t(numbering.used) + 1, 0u);
    forParts(parts, uniqueCount, [&](uint32_t part, size_t vb, size_t ve) {
        uint32_t id = partUsed[part], start = partRows[part];
        for (size_t u = vb; u < ve; ++u) {
            if (rowSize[u] == 0) continue;
            numbering.compact[u] = id;
            numbering.newStart[id++] = start;
            start += rowSize[u];
        }
    });
    numbering.newStart[numbering.used] = partRows[parts];
    return numbering;
}

// The kept triangles, each repeated by its group's net copies (flipped when negative), over the
// output vertices.
std::vector<glm::uvec3> netWindingTriangles(const std::vector<glm::uvec3>& tris,
                                            const std::vector<uint8_t>& duplicate,
                                            const std::vector<int32_t>& net,
                                            const std::vector<uint32_t>& compact) {
    std::vector<glm::uvec3> winding;
    reserveHuge(winding, tris.size());
    for (size_t t = 0; t < tris.size(); ++t) {
        if (duplicate[t]) continue;
        const int copies = net[t];
        const glm::uvec3 c(compact[tris[t].x], compact[tris[t].y], compact[tris[t].z]);
        for (int i = 0; i < std::abs(copies); ++i)
            winding.push_back(copies > 0 ? c : glm::uvec3(c.x, c.z, c.y));
    }
    return winding;
}

// out.positions: the used vertices in double coordinates relative to out.center.
void placeVertices(const assets::MeshData& mesh, const std::vector<uint32_t>& uniqueSource,
                   const VertexNumbering& numbering, uint32_t parts, CleanMesh& out) {
    resizeHuge(out.positions, numbering.used);
    forParts(parts, uniqueSource.size(), [&](uint32_t, size_t vb, size_t ve) {
        for (size_t u = vb; u < ve; ++u) {
            if (numbering.compact[u] != kNone) {
                out.positions[numbering.compact[u]] =
                    glm::dvec3(mesh.positions[uniqueSource[u]]) - out.center;
            }
        }
    });
}

// Signed volume, summed in triangle order (the same for any thread count).
double signedVolume(const CleanMesh& mesh) {
    double volume = 0;
    for (const glm::uvec3& t : mesh.triangles) {
        volume += glm::dot(mesh.positions[t.x], glm::cross(mesh.positions[t.y], mesh.positions[t.z]));
    }
    return volume / 6;
}

bool cleanMeshImpl(const assets::MeshData& mesh, CleanMesh& out, std::string& error, uint32_t threads) {
    out = CleanMesh{};
    MeshDiagnostics& diag = out.diagnostics;
    diag.inputVertices = mesh.positions.size();
    diag.inputTriangles = mesh.indices.size() / 3;
    if (!validateMesh(mesh, error)) return false;
    const size_t triangleCount = mesh.indices.size() / 3;

    MergedVertices merged = mergeCoincidentVertices(mesh);
    diag.duplicateVerticesMerged = merged.referenced - merged.uniqueSource.size();

    // The remaining steps run in `parts` threads: triangle ranges for the degenerate test, vertex
    // ranges (rows) for the rings, duplicates and edges. Results do not depend on the split.
    const std::vector<uint32_t>& uniqueSource = merged.uniqueSource;
    const size_t uniqueCount = uniqueSource.size();
    const uint32_t parts = partsFor(threads, triangleCount);

    std::vector<glm::uvec3> tris = dropDegenerateTriangles(mesh, merged, parts, diag);
    merged.remap = {};
    Rings rings = buildRings(tris, uniqueCount, parts);

    std::vector<uint8_t> duplicate;
    resizeHuge(duplicate, tris.size(), uint8_t(0));
    std::vector<PartCounts> counts(parts);
    findDuplicateTriangles(rings, uniqueCount, parts, duplicate, counts);
    countEdgeUses(rings, uniqueCount, parts, duplicate, counts);
    const std::vector<int32_t> net = sumPartCounts(counts, tris.size(), diag);

    // Winding triangles: only needed when some duplicate group's net orientation is not one copy
    // of its first triangle.
    bool windingDiffers = false;
    for (size_t t = 0; t < net.size() && !windingDiffers; ++t) windingDiffers = net[t] != 1;

    // Compaction: drop duplicates, renumber the used vertices (input order), move them to double
    // coordinates relative to the bounding-box centre, and compact the rings alike.
    std::vector<uint32_t> newTriangle;
    resizeHuge(newTriangle, tris.size(), kNone);
    uint32_t keptTriangles = 0;
    for (size_t t = 0; t < tris.size(); ++t) {
        if (!duplicate[t]) newTriangle[t] = keptTriangles++;
    }
    VertexNumbering numbering = numberUsedVertices(mesh, uniqueSource, rings, duplicate, parts);
    const std::vector<uint32_t>& compact = numbering.compact;
    out.separateWinding = windingDiffers;
    if (windingDiffers) out.windingTriangles = netWindingTriangles(tris, duplicate, net, compact);
    resizeHuge(out.ringTriangles, size_t(keptTriangles) * 3, 0u);
    forParts(parts, uniqueCount, [&](uint32_t, size_t vb, size_t ve) {
        for (size_t u = vb; u < ve; ++u) {
            if (compact[u] == kNone) continue;
            uint32_t w = numbering.newStart[compact[u]];
            for (uint32_t r = rings.start[u]; r < rings.start[u + 1]; ++r) {
                const uint32_t t = rings.entries[r].triangle;
                if (!duplicate[t]) out.ringTriangles[w++] = newTriangle[t];
            }
        }
    });
    out.ringStart = std::move(numbering.newStart);
    rings = {};
    for (size_t t = 0; t < tris.size(); ++t) {  // in place: newTriangle[t] <= t
        if (!duplicate[t]) {
            tris[newTriangle[t]] = glm::uvec3(compact[tris[t].x], compact[tris[t].y], compact[tris[t].z]);
        }
    }
    tris.resize(keptTriangles);
    out.triangles = std::move(tris);

    diag.triangles = keptTriangles;
    diag.vertices = numbering.used;
    if (keptTriangles == 0) {
        diag.boundsMin = diag.boundsMax = glm::dvec3(0);
        return true;
    }
    diag.boundsMin = numbering.lo;
    diag.boundsMax = numbering.hi;
    out.center = 0.5 * (numbering.lo + numbering.hi);
    placeVertices(mesh, uniqueSource, numbering, parts, out);
    diag.signedVolume = signedVolume(out);
    diag.inwardOriented = diag.closedManifold && diag.inconsistentEdges == 0 && diag.signedVolume < 0;
    return true;
}

}  // namespace

bool cleanMesh(const assets::MeshData& mesh, CleanMesh& out, std::string& error, uint32_t threads) {
    try {
        return cleanMeshImpl(mesh, out, error, threads);
    } catch (const std::bad_alloc&) {
        out = CleanMesh{};
        error = fmt::format("out of memory cleaning a mesh of {} triangles", mesh.indices.size() / 3);
    } catch (const std::length_error&) {
        out = CleanMesh{};
        error = fmt::format("out of memory cleaning a mesh of {} triangles", mesh.indices.size() / 3);
    }
    return false;
}

}  // namespace penumbra::sdf
