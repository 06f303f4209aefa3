// The scene renderer's camera in double precision, for tests that cast exact rays per pixel
// (renderer/scene_renderer.cpp documents the camera: the basis without scale, Vulkan's y-down
// pixel rows, pixel centres at +0.5; the SDF trace builds its rays the same way).
#pragma once

#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

#include "engine/ecs/components.h"
#include "engine/ecs/world.h"

namespace penumbra::test {

struct RefCamera {
    glm::dvec3 eye, forward, right, up;
    double tanHalf = 0, aspect = 1, nearPlane = 0.1, farPlane = 100;
    uint32_t w = 0, h = 0;

    RefCamera(const ecs::World& world, ecs::Entity cam, uint32_t width, uint32_t height)
        : w(width), h(height) {
        const glm::dmat4 m(world.get<ecs::Transform>(cam)->worldMatrix);
        const ecs::Camera& c = *world.get<ecs::Camera>(cam);
        const glm::dvec3 z = glm::normalize(glm::dvec3(m[2]));
        glm::dvec3 x = glm::dvec3(m[0]);
        x = glm::normalize(x - z * glm::dot(x, z));
        forward = -z;
        right = x;
        up = glm::cross(z, x);
        eye = glm::dvec3(m[3]);
        tanHalf = std::tan(double(c.fovY) * 0.5);
        aspect = double(width) / double(height);
        nearPlane = c.nearPlane;
        farPlane = c.farPlane;
    }
    // The ray through pixel (x, y), unnormalised: its component along `forward` is 1, so linear
    // depth = t / |dir| for unit rays.
    glm::dvec3 dir(uint32_t x, uint32_t y) const {
        const double nx = (x + 0.5) / w * 2.0 - 1.0, ny = (y + 0.5) / h * 2.0 - 1.0;
        return forward + nx * aspect * tanHalf * right - ny * tanHalf * up;
    }
    // Pixel position (x right, y down, pixel centres at +0.5) of a world point in front of the camera.
    glm::dvec2 project(glm::dvec3 p) const {
        const glm::dvec3 v = p - eye;
        const double cz = glm::dot(v, forward);
        const double nx = glm::dot(v, right) / (cz * aspect * tanHalf),
                     ny = -glm::dot(v, up) / (cz * tanHalf);
        return {(nx * 0.5 + 0.5) * w, (ny * 0.5 + 0.5) * h};
    }
    // Size of one pixel per unit of linear depth (the trace's footprint: 2 tan(fov/2) / height).
    double footprint() const { return 2.0 * tanHalf / double(h); }
};

}  // namespace penumbra::test
