// Exact point-to-triangle distance in double precision with Voronoi-region tests (the method of
// Ericson, Real-Time Collision Detection 5.1.5), reporting which feature of the triangle (face,
// edge or vertex) holds the closest point: the angle-weighted pseudonormal sign needs it.
#pragma once

#include <cstdint>

#include <glm/vec3.hpp>

namespace penumbra::sdf {

// Edge k joins vertex k and vertex (k + 1) % 3.
enum class TriangleFeature : uint8_t { Face, Edge01, Edge12, Edge20, Vertex0, Vertex1, Vertex2 };

inline bool isEdge(TriangleFeature f) {
    return f == TriangleFeature::Edge01 || f == TriangleFeature::Edge12 || f == TriangleFeature::Edge20;
}
inline bool isVertex(TriangleFeature f) {
    return f == TriangleFeature::Vertex0 || f == TriangleFeature::Vertex1 || f == TriangleFeature::Vertex2;
}
// Index 0..2 of the edge or vertex (0 for the face).
inline uint32_t featureIndex(TriangleFeature f) {
    switch (f) {
        case TriangleFeature::Edge12:
        case TriangleFeature::Vertex1:
            return 1;
        case TriangleFeature::Edge20:
        case TriangleFeature::Vertex2:
            return 2;
        default:
            return 0;
    }
}

struct TriangleClosest {
    glm::dvec3 point{0};
    double distanceSquared = 0;
    TriangleFeature feature = TriangleFeature::Face;
};

// Closest point of triangle (a, b, c) to p. Degenerate (zero-area) triangles are handled as the
// union of their edges.
TriangleClosest closestPointOnTriangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                       const glm::dvec3& c);

// Squared distance only (same arithmetic as closestPointOnTriangle).
double pointTriangleDistanceSquared(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                    const glm::dvec3& c);

// Closest point on segment [a, b] to p; t in [0,1] is the parameter of the closest point.
glm::dvec3 closestPointOnSegment(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, double& t);

}  // namespace penumbra::sdf
