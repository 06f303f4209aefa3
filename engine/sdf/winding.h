// Inside/outside tests for arbitrary (open, non-manifold) triangle soups:
// - generalized winding number (Jacobson et al. 2013): exact O(n) sum of solid angles, and a fast
//   hierarchical approximation (Barill et al. 2018: BVH, per-node dipole expansion, exact near
//   field) with accuracy parameter beta;
// - parity: ray crossing count (robust against rays through edges/vertices).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/vec3.hpp>

namespace penumbra::sdf {

class WindingNumber {
public:
    // Keeps references to the arrays: they must outlive this object. Triangles with an index out of
    // range or zero (or non-finite) area are ignored everywhere; the others are oriented (counter-
    // clockwise seen from outside gives w = 1 inside a closed surface). Builds the tree for fast()
    // and parityInside(), single-threaded: ~110 ms CPU and ~73 bytes per triangle (+32 while
    // building) for the 871k-triangle dragon. beta: a tree node is replaced by its expansion when
    // the query is farther than beta times the node's radius; larger is more accurate and slower
    // (beta 2: |fast - exact| <= 0.065 in the tests; 1.5: ~1.8x faster, about twice the error; a
    // non-positive or non-finite beta means 2).
    WindingNumber(const std::vector<glm::dvec3>& positions, const std::vector<glm::uvec3>& triangles,
                  double beta = 2.0);
    ~WindingNumber();
    WindingNumber(WindingNumber&&) noexcept;
    WindingNumber& operator=(WindingNumber&&) noexcept;

    // Exact generalized winding number (sum of signed solid angles / 4 pi), in double. O(n).
    // Undefined on the surface itself; NaN for a non-finite p.
    double exact(const glm::dvec3& p) const;
    // Hierarchical approximation: dipole + first-moment expansion of far nodes, exact solid angles
    // (float) of near leaves. Thread-safe, no allocation; NaN for a non-finite p.
    double fast(const glm::dvec3& p) const;
    // Inside by ray-crossing parity (odd = inside), majority of three rays (watertight ray/triangle
    // tests). Meaningful for closed meshes; on open ones it is whatever the rays see. Thread-safe,
    // no allocation; false for a non-finite p.
    bool parityInside(const glm::dvec3& p) const;

    // The three ray directions parityInside() votes with (default: fixed irrational directions).
    // Any non-zero directions work, axis-aligned ones included: rays exactly through an edge or a
    // vertex are counted once. Not thread-safe: set before querying.
    void setParityDirections(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
};

}  // namespace penumbra::sdf
