// The G-buffer encodings of renderer/shaders/gbuffer.glsl, in C++ (tests, tools, CPU-side
// readbacks): the octahedral normal encoding, unit vector <-> [-1, 1]^2. Change both together.
#pragma once

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace penumbra::render {

inline glm::vec2 octEncode(glm::vec3 n) {
    const float l1 = std::abs(n.x) + std::abs(n.y) + std::abs(n.z);
    glm::vec2 p = glm::vec2(n.x, n.y) / l1;
    if (n.z >= 0.0f) return p;
    return glm::vec2((1.0f - std::abs(p.y)) * (p.x >= 0.0f ? 1.0f : -1.0f),
                     (1.0f - std::abs(p.x)) * (p.y >= 0.0f ? 1.0f : -1.0f));
}

inline glm::vec3 octDecode(glm::vec2 e) {
    glm::vec3 n(e.x, e.y, 1.0f - std::abs(e.x) - std::abs(e.y));
    const float t = std::max(-n.z, 0.0f);
    n.x += n.x >= 0.0f ? -t : t;
    n.y += n.y >= 0.0f ? -t : t;
    return glm::normalize(n);
}

}  // namespace penumbra::render
