// Procedural primitive meshes: sphere, box, plane, capped cylinder, torus.
//
// Conventions: right-handed, +Y up, centred on the origin; triangles are counter-clockwise seen
// from outside (the front face), normals are unit and point outward, uvs in [0, 1]. Vertices are
// duplicated along uv seams and hard edges (box edges, cylinder rims), so the index buffer is not
// watertight by itself; merging vertices at identical positions makes every closed shape (sphere,
// box, cylinder, torus) watertight: each edge is then shared by exactly two triangles. Seam and
// pole vertices reuse the same sine/cosine values, so "identical" is exact, not approximate.
//
// Every function validates its parameters (finite and > 0, segment counts in the documented
// ranges) and returns false with a message naming the shape, the parameter and the reason.
#pragma once

#include <cstdint>
#include <string>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "engine/assets/mesh.h"

namespace penumbra::assets {

// Segment-count ranges (inclusive) accepted by the builders below.
inline constexpr uint32_t kMinPrimitiveSegments = 3;  // around an axis (sphere, cylinder, torus)
inline constexpr uint32_t kMinSphereRings = 2;        // pole to pole
inline constexpr uint32_t kMaxPrimitiveSegments = 1024;

enum class PrimitiveShape : uint8_t { Sphere, Box, Plane, Cylinder, Torus };

const char* primitiveShapeName(PrimitiveShape shape);  // "sphere", "box", ...
bool parsePrimitiveShape(const std::string& name, PrimitiveShape& out);

// The parameters of one primitive; each shape reads only its own fields.
struct PrimitiveDesc {
    PrimitiveShape shape = PrimitiveShape::Sphere;
    float radius = 0.5f;          // sphere, cylinder
    uint32_t segments = 32;       // sphere (longitude), cylinder (around the axis)
    uint32_t rings = 16;          // sphere (latitude bands); torus: segments around the ring
    glm::vec3 halfExtents{0.5f};  // box
    glm::vec2 halfSize{1.0f};     // plane: half size along x and z
    float halfHeight = 0.5f;      // cylinder: along y
    float majorRadius = 0.5f;     // torus: ring radius in the xz plane
    float minorRadius = 0.15f;    // torus: tube radius (< majorRadius)
    uint32_t sides = 16;          // torus: segments around the tube
};

// Sphere of `radius`: `segments` in [3, 1024] around +Y, `rings` in [2, 1024] from pole to pole.
// (segments + 1) * (rings + 1) vertices, 2 * segments * (rings - 1) triangles.
bool makeSphere(float radius, uint32_t segments, uint32_t rings, MeshData& out, std::string& error);
// Axis-aligned box: 24 vertices (4 per face, flat normals), 12 triangles.
bool makeBox(glm::vec3 halfExtents, MeshData& out, std::string& error);
// Plane y = 0 facing +Y, spanning [-halfSize.x, halfSize.x] x [-halfSize.y, halfSize.y] in x, z:
// 4 vertices, 2 triangles (single-sided).
bool makePlane(glm::vec2 halfSize, MeshData& out, std::string& error);
// Cylinder along y in [-halfHeight, halfHeight], capped at both ends; `segments` in [3, 1024].
// 4 * (segments + 1) + 2 vertices, 4 * segments triangles.
bool makeCylinder(float radius, float halfHeight, uint32_t segments, MeshData& out, std::string& error);
// Torus around +Y: `rings` in [3, 1024] segments around the ring, `sides` in [3, 1024] around the
// tube; 0 < minorRadius < majorRadius. (rings + 1) * (sides + 1) vertices, 2 * rings * sides
// triangles.
bool makeTorus(float majorRadius, float minorRadius, uint32_t rings, uint32_t sides, MeshData& out,
               std::string& error);

// Dispatches on desc.shape.
bool makePrimitive(const PrimitiveDesc& desc, MeshData& out, std::string& error);

// The asset key naming this primitive, built from the shape's own parameters only, so identical
// primitives share one mesh asset, e.g. "primitive:sphere:r=0.5:seg=32:rings=16",
// "primitive:box:h=1,0.5,0.25". Numbers are printed in their shortest round-trip form.
std::string primitiveKey(const PrimitiveDesc& desc);

}  // namespace penumbra::assets
