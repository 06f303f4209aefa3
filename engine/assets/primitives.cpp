#include "engine/assets/primitives.h"

#include <cmath>
#include <numbers>
#include <vector>

#include <fmt/format.h>
#include <glm/geometric.hpp>

namespace penumbra::assets {
namespace {

constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;
constexpr float kPi = std::numbers::pi_v<float>;

// Largest accepted length parameter: keeps every derived coordinate finite in float.
constexpr float kMaxLength = 1e18f;

bool checkLength(const char* shape, const char* param, float value, std::string& error) {
    if (!std::isfinite(value) || value <= 0.0f || value > kMaxLength) {
        error =
            fmt::format("{}: {} must be finite, > 0 and <= {:g} (got {})", shape, param, kMaxLength, value);
        return false;
    }
    return true;
}

bool checkCount(const char* shape, const char* param, uint32_t value, uint32_t lo, std::string& error) {
    if (value < lo || value > kMaxPrimitiveSegments) {
        error = fmt::format("{}: {} must be in [{}, {}] (got {})", shape, param, lo, kMaxPrimitiveSegments,
                            value);
        return false;
    }
    return true;
}

// cos/sin of 2*pi*i/n for i = 0..n, with entry n an exact copy of entry 0 (closed seams).
void unitCircle(uint32_t n, std::vector<float>& cosines, std::vector<float>& sines) {
    cosines.resize(n + 1);
    sines.resize(n + 1);
    for (uint32_t i = 0; i < n; ++i) {
        const float a = kTwoPi * float(i) / float(n);
        cosines[i] = std::cos(a);
        sines[i] = std::sin(a);
    }
    cosines[n] = cosines[0];
    sines[n] = sines[0];
}

void begin(MeshData& mesh, size_t vertices, size_t triangles, std::string sourcePath) {
    mesh = MeshData{};
    mesh.positions.reserve(vertices);
    mesh.normals.reserve(vertices);
    mesh.uvs.reserve(vertices);
    mesh.indices.reserve(triangles * 3);
    mesh.sourcePath = std::move(sourcePath);
}

void vertex(MeshData& mesh, glm::vec3 p, glm::vec3 n, glm::vec2 uv) {
    mesh.positions.push_back(p);
    mesh.normals.push_back(n);
    mesh.uvs.push_back(uv);
}

void triangle(MeshData& mesh, uint32_t a, uint32_t b, uint32_t c) {
    mesh.indices.push_back(a);
    mesh.indices.push_back(b);
    mesh.indices.push_back(c);
}

}  // namespace

const char* primitiveShapeName(PrimitiveShape shape) {
    switch (shape) {
        case PrimitiveShape::Sphere:
            return "sphere";
        case PrimitiveShape::Box:
            return "box";
        case PrimitiveShape::Plane:
            return "plane";
        case PrimitiveShape::Cylinder:
            return "cylinder";
        case PrimitiveShape::Torus:
            return "torus";
    }
    return "unknown";
}

bool parsePrimitiveShape(const std::string& name, PrimitiveShape& out) {
    for (PrimitiveShape s : {PrimitiveShape::Sphere, PrimitiveShape::Box, PrimitiveShape::Plane,
                             PrimitiveShape::Cylinder, PrimitiveShape::Torus}) {
        if (name == primitiveShapeName(s)) {
            out = s;
            return true;
        }
    }
    return false;
}

// Vertex (i, j): polar angle theta = pi * i / rings from +Y, azimuth phi = 2 pi j / segments from
// +Z towards +X. With d/dtheta pointing "down" and d/dphi "east", (v(i,j), v(i+1,j), v(i,j+1)) is
// counter-clockwise seen from outside.
bool makeSphere(float radius, uint32_t segments, uint32_t rings, MeshData& out, std::string& error) {
    if (!checkLength("sphere", "radius", radius, error) ||
        !checkCount("sphere", "segments", segments, kMinPrimitiveSegments, error) ||
        !checkCount("sphere", "rings", rings, kMinSphereRings, error)) {
        return false;
    }
    MeshData mesh;
    begin(mesh, size_t(segments + 1) * (rings + 1), size_t(2) * segments * (rings - 1), "primitive:sphere");
    std::vector<float> cosPhi, sinPhi;
    unitCircle(segments, cosPhi, sinPhi);
    for (uint32_t i = 0; i <= rings; ++i) {
        float sinTheta = std::sin(kPi * float(i) / float(rings));
        float cosTheta = std::cos(kPi * float(i) / float(rings));
        if (i == 0 || i == rings) {  // exact poles
            sinTheta = 0.0f;
            cosTheta = i == 0 ? 1.0f : -1.0f;
        }
        for (uint32_t j = 0; j <= segments; ++j) {
            const glm::vec3 n(sinTheta * sinPhi[j], cosTheta, sinTheta * cosPhi[j]);
            vertex(mesh, radius * n, n, glm::vec2(float(j) / float(segments), float(i) / float(rings)));
        }
    }
    const uint32_t row = segments + 1;
    for (uint32_t i = 0; i < rings; ++i) {
        for (uint32_t j = 0; j < segments; ++j) {
            const uint32_t a = i * row + j;               // (i, j)
            const uint32_t b = a + row;                   // (i + 1, j)
            const uint32_t c = a + 1;                     // (i, j + 1)
            const uint32_t d = b + 1;                     // (i + 1, j + 1)
            if (i != 0) triangle(mesh, a, b, c);          // degenerate in the top band (a = c = pole)
            if (i != rings - 1) triangle(mesh, c, b, d);  // degenerate in the bottom band (b = d = pole)
        }
    }
    out = std::move(mesh);
    return true;
}

bool makeBox(glm::vec3 halfExtents, MeshData& out, std::string& error) {
    if (!checkLength("box", "halfExtents.x", halfExtents.x, error) ||
        !checkLength("box", "halfExtents.y", halfExtents.y, error) ||
        !checkLength("box", "halfExtents.z", halfExtents.z, error)) {
        return false;
    }
    MeshData mesh;
    begin(mesh, 24, 12, "primitive:box");
    // Each face: outward normal n and "up" axis v; u = cross(v, n) so that cross(u, v) = n and the
    // corners (-u-v, +u-v, +u+v, -u+v) run counter-clockwise seen from outside.
    const glm::vec3 faces[6][2] = {
        {{1, 0, 0}, {0, 1, 0}},  {{-1, 0, 0}, {0, 1, 0}}, {{0, 0, 1}, {0, 1, 0}},
        {{0, 0, -1}, {0, 1, 0}}, {{0, 1, 0}, {0, 0, -1}}, {{0, -1, 0}, {0, 0, 1}},
    };
    const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (const auto& face : faces) {
        const glm::vec3 n = face[0];
        const glm::vec3 v = face[1];
        const glm::vec3 u = glm::cross(v, n);
        const uint32_t base = uint32_t(mesh.positions.size());
        for (const auto& c : corners) {
            const glm::vec3 p = (n + c[0] * u + c[1] * v) * halfExtents;
            vertex(mesh, p, n, glm::vec2((c[0] + 1.0f) * 0.5f, (1.0f - c[1]) * 0.5f));
        }
        triangle(mesh, base, base + 1, base + 2);
        triangle(mesh, base, base + 2, base + 3);
    }
    out = std::move(mesh);
    return true;
}

bool makePlane(glm::vec2 halfSize, MeshData& out, std::string& error) {
    if (!checkLength("plane", "halfSize.x", halfSize.x, error) ||
        !checkLength("plane", "halfSize.z", halfSize.y, error)) {
        return false;
    }
    MeshData mesh;
    begin(mesh, 4, 2, "primitive:plane");
    const glm::vec3 n(0.0f, 1.0f, 0.0f);
    const float x = halfSize.x;
    const float z = halfSize.y;
    // Counter-clockwise seen from +Y: u = +X, v = -Z.
    vertex(mesh, {-x, 0.0f, z}, n, {0.0f, 1.0f});
    vertex(mesh, {x, 0.0f, z}, n, {1.0f, 1.0f});
    vertex(mesh, {x, 0.0f, -z}, n, {1.0f, 0.0f});
    vertex(mesh, {-x, 0.0f, -z}, n, {0.0f, 0.0f});
    triangle(mesh, 0, 1, 2);
    triangle(mesh, 0, 2, 3);
    out = std::move(mesh);
    return true;
}

bool makeCylinder(float radius, float halfHeight, uint32_t segments, MeshData& out, std::string& error) {
    if (!checkLength("cylinder", "radius", radius, error) ||
        !checkLength("cylinder", "halfHeight", halfHeight, error) ||
        !checkCount("cylinder", "segments", segments, kMinPrimitiveSegments, error)) {
        return false;
    }
    MeshData mesh;
    begin(mesh, size_t(4) * (segments + 1) + 2, size_t(4) * segments, "primitive:cylinder");
    std::vector<float> cosPhi, sinPhi;
    unitCircle(segments, cosPhi, sinPhi);
    // Side: bottom ring then top ring; azimuth from +Z towards +X as for the sphere.
    for (uint32_t k = 0; k < 2; ++k) {
        const float y = k == 0 ? -halfHeight : halfHeight;
        for (uint32_t j = 0; j <= segments; ++j) {
            const glm::vec3 n(sinPhi[j], 0.0f, cosPhi[j]);
            vertex(mesh, glm::vec3(radius * sinPhi[j], y, radius * cosPhi[j]), n,
                   glm::vec2(float(j) / float(segments), k == 0 ? 1.0f : 0.0f));
        }
    }
    const uint32_t row = segments + 1;
    for (uint32_t j = 0; j < segments; ++j) {
        const uint32_t b0 = j, b1 = j + 1, t0 = row + j, t1 = row + j + 1;
        triangle(mesh, b0, b1, t0);
        triangle(mesh, b1, t1, t0);
    }
    // Caps: a centre vertex and a ring with the cap's normal.
    for (uint32_t k = 0; k < 2; ++k) {
        const bool top = k == 1;
        const float y = top ? halfHeight : -halfHeight;
        const glm::vec3 n(0.0f, top ? 1.0f : -1.0f, 0.0f);
        const uint32_t centre = uint32_t(mesh.positions.size());
        vertex(mesh, glm::vec3(0.0f, y, 0.0f), n, glm::vec2(0.5f));
        for (uint32_t j = 0; j <= segments; ++j) {
            vertex(mesh, glm::vec3(radius * sinPhi[j], y, radius * cosPhi[j]), n,
                   glm::vec2(0.5f + 0.5f * sinPhi[j], 0.5f - 0.5f * (top ? 1.0f : -1.0f) * cosPhi[j]));
        }
        for (uint32_t j = 0; j < segments; ++j) {
            if (top) {
                triangle(mesh, centre, centre + 1 + j, centre + 2 + j);
            } else {
                triangle(mesh, centre, centre + 2 + j, centre + 1 + j);
            }
        }
    }
    out = std::move(mesh);
    return true;
}

// Vertex (i, j): ring angle u = 2 pi i / rings about +Y (from +Z towards +X), tube angle
// v = 2 pi j / sides (0 = outermost, then up). d/du x d/dv points outward, so
// (p(i,j), p(i+1,j), p(i,j+1)) is counter-clockwise seen from outside.
bool makeTorus(float majorRadius, float minorRadius, uint32_t rings, uint32_t sides, MeshData& out,
               std::string& error) {
    if (!checkLength("torus", "majorRadius", majorRadius, error) ||
        !checkLength("torus", "minorRadius", minorRadius, error) ||
        !checkCount("torus", "rings", rings, kMinPrimitiveSegments, error) ||
        !checkCount("torus", "sides", sides, kMinPrimitiveSegments, error)) {
        return false;
    }
    if (!(minorRadius < majorRadius)) {
        error = fmt::format(
            "torus: minorRadius ({}) must be smaller than majorRadius ({}) (the tube would "
            "intersect itself)",
            minorRadius, majorRadius);
        return false;
    }
    MeshData mesh;
    begin(mesh, size_t(rings + 1) * (sides + 1), size_t(2) * rings * sides, "primitive:torus");
    std::vector<float> cosU, sinU, cosV, sinV;
    unitCircle(rings, cosU, sinU);
    unitCircle(sides, cosV, sinV);
    for (uint32_t i = 0; i <= rings; ++i) {
        const glm::vec3 radial(sinU[i], 0.0f, cosU[i]);
        for (uint32_t j = 0; j <= sides; ++j) {
            const glm::vec3 n = cosV[j] * radial + glm::vec3(0.0f, sinV[j], 0.0f);
            const glm::vec3 p = majorRadius * radial + minorRadius * n;
            vertex(mesh, p, n, glm::vec2(float(i) / float(rings), float(j) / float(sides)));
        }
    }
    const uint32_t row = sides + 1;
    for (uint32_t i = 0; i < rings; ++i) {
        for (uint32_t j = 0; j < sides; ++j) {
            const uint32_t a = i * row + j;  // (i, j)
            const uint32_t b = a + row;      // (i + 1, j)
            const uint32_t c = a + 1;        // (i, j + 1)
            const uint32_t d = b + 1;        // (i + 1, j + 1)
            triangle(mesh, a, b, c);
            triangle(mesh, b, d, c);
        }
    }
    out = std::move(mesh);
    return true;
}

bool makePrimitive(const PrimitiveDesc& desc, MeshData& out, std::string& error) {
    switch (desc.shape) {
        case PrimitiveShape::Sphere:
            return makeSphere(desc.radius, desc.segments, desc.rings, out, error);
        case PrimitiveShape::Box:
            return makeBox(desc.halfExtents, out, error);
        case PrimitiveShape::Plane:
            return makePlane(desc.halfSize, out, error);
        case PrimitiveShape::Cylinder:
            return makeCylinder(desc.radius, desc.halfHeight, desc.segments, out, error);
        case PrimitiveShape::Torus:
            return makeTorus(desc.majorRadius, desc.minorRadius, desc.rings, desc.sides, out, error);
    }
    error = "primitive: unknown shape";
    return false;
}

std::string primitiveKey(const PrimitiveDesc& desc) {
    switch (desc.shape) {
        case PrimitiveShape::Sphere:
            return fmt::format("primitive:sphere:r={}:seg={}:rings={}", desc.radius, desc.segments,
                               desc.rings);
        case PrimitiveShape::Box:
            return fmt::format("primitive:box:h={},{},{}", desc.halfExtents.x, desc.halfExtents.y,
                               desc.halfExtents.z);
        case PrimitiveShape::Plane:
            return fmt::format("primitive:plane:h={},{}", desc.halfSize.x, desc.halfSize.y);
        case PrimitiveShape::Cylinder:
            return fmt::format("primitive:cylinder:r={}:hh={}:seg={}", desc.radius, desc.halfHeight,
                               desc.segments);
        case PrimitiveShape::Torus:
            return fmt::format("primitive:torus:R={}:r={}:rings={}:sides={}", desc.majorRadius,
                               desc.minorRadius, desc.rings, desc.sides);
    }
    return "primitive:unknown";
}

}  // namespace penumbra::assets
