#include "engine/sdf/distance.h"

#include <algorithm>

#include <glm/geometric.hpp>

namespace penumbra::sdf {

glm::dvec3 closestPointOnSegment(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, double& t) {
    const glm::dvec3 ab = b - a;
    const double len2 = glm::dot(ab, ab);
    t = len2 > 0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
    return a + ab * t;
}

namespace {

// Closest point on a zero-area triangle: the best of its three edges.
TriangleClosest closestOnDegenerate(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                    const glm::dvec3& c) {
    const glm::dvec3* v[3] = {&a, &b, &c};
    TriangleClosest best;
    best.distanceSquared = -1;
    for (int e = 0; e < 3; ++e) {
        double t = 0;
        const glm::dvec3 q = closestPointOnSegment(p, *v[e], *v[(e + 1) % 3], t);
        const glm::dvec3 d = p - q;
        const double d2 = glm::dot(d, d);
        if (best.distanceSquared < 0 || d2 < best.distanceSquared) {
            best.distanceSquared = d2;
            best.point = q;
            if (t <= 0) {
                best.feature = static_cast<TriangleFeature>(uint8_t(TriangleFeature::Vertex0) + e);
            } else if (t >= 1) {
                best.feature = static_cast<TriangleFeature>(uint8_t(TriangleFeature::Vertex0) + (e + 1) % 3);
            } else {
                best.feature = static_cast<TriangleFeature>(uint8_t(TriangleFeature::Edge01) + e);
            }
        }
    }
    return best;
}

inline TriangleClosest makeResult(const glm::dvec3& p, const glm::dvec3& q, TriangleFeature f) {
    const glm::dvec3 d = p - q;
    return TriangleClosest{q, glm::dot(d, d), f};
}

}  // namespace

// Voronoi-region classification: the closest point lies in the region of a vertex, of an edge or
// of the face. Each test uses dot products of the edge vectors with the vectors from the
// vertices to p; the edge tests use the (scaled) barycentric coordinates of p's projection.
TriangleClosest closestPointOnTriangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                       const glm::dvec3& c) {
    const glm::dvec3 ab = b - a;
    const glm::dvec3 ac = c - a;

    // Region of vertex a: p projects behind a along both edges leaving a.
    const glm::dvec3 ap = p - a;
    const double d1 = glm::dot(ab, ap);
    const double d2 = glm::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return makeResult(p, a, TriangleFeature::Vertex0);

    // Region of vertex b.
    const glm::dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp);
    const double d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return makeResult(p, b, TriangleFeature::Vertex1);

    // Region of edge ab: the barycentric weight of c is not positive and p lies between a and b.
    const double wc = d1 * d4 - d3 * d2;
    if (wc <= 0 && d1 >= 0 && d3 <= 0 && d1 - d3 > 0) {
        const double t = d1 / (d1 - d3);
        return makeResult(p, a + ab * t, TriangleFeature::Edge01);
    }

    // Region of vertex c.
    const glm::dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp);
    const double d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return makeResult(p, c, TriangleFeature::Vertex2);

    // Region of edge ca.
    const double wb = d5 * d2 - d1 * d6;
    if (wb <= 0 && d2 >= 0 && d6 <= 0 && d2 - d6 > 0) {
        const double t = d2 / (d2 - d6);
        return makeResult(p, a + ac * t, TriangleFeature::Edge20);
    }

    // Region of edge bc.
    const double wa = d3 * d6 - d5 * d4;
    const double e1 = d4 - d3;
    const double e2 = d5 - d6;
    if (wa <= 0 && e1 >= 0 && e2 >= 0 && e1 + e2 > 0) {
        const double t = e1 / (e1 + e2);
        return makeResult(p, b + (c - b) * t, TriangleFeature::Edge12);
    }

    // Face region: the projection of p is inside the triangle. wa + wb + wc = |ab x ac|^2.
    const double sum = wa + wb + wc;
    if (!(sum > 0)) return closestOnDegenerate(p, a, b, c);
    const double v = wb / sum;
    const double w = wc / sum;
    return makeResult(p, a + ab * v + ac * w, TriangleFeature::Face);
}

double pointTriangleDistanceSquared(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                    const glm::dvec3& c) {
    return closestPointOnTriangle(p, a, b, c).distanceSquared;
}

}  // namespace penumbra::sdf
