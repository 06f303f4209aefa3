// The CPU reference renderer (docs/ACCURACY.md): renders a scene from its original geometry —
// triangle meshes by ray–triangle intersection over Embree's BVH, the hit distance then recomputed
// in double precision on the hit triangle's plane, analytic spheres and planes by exact
// intersection in double precision, SDF shape programs by sphere tracing and root bracketing on the
// double-precision program, MeshBake objects as their original mesh and .psdf fields as their
// trilinear interpolant — into float AOVs with the rasterizer's camera, pixel-centre and
// AOV conventions (docs/FORMATS.md, "AOV images"):
//
//   depth   linear view depth along the camera's -Z (scene units), 0 where nothing is hit
//   normal  world-space unit normal (meshes: interpolated vertex normal; analytic: exact), 0 on miss
//   ids     entity index (analytic shapes: the id given to add*), -1 on miss
//   ao      cosine-weighted fraction of hemisphere rays unoccluded within aoMaxDistance
//   shadowN visible fraction of shadowed light N (sphere: of its solid angle; directional with an
//           angular radius: of its cone; point, zero radius or zero angle: binary)
//
//   std::string error;
//   auto scene = reference::ReferenceScene::create(error);
//   reference::buildFromWorld(world, assets, *scene, error);   // or addMesh / addSphere / addPlane
//   scene->commit();
//   reference::ReferenceCamera cam;
//   reference::makeCamera(world, cameraEntity, width, height, cam, error);
//   reference::RenderDesc desc{...};
//   std::vector<reference::AovImage> images;
//   reference::render(*scene, cam, desc, images, error);
//
// Monte Carlo estimates use a jittered k x k grid of equal-probability strata per pixel (seeded
// from the pixel, the AOV and RenderDesc::seed: deterministic whatever the thread count); each
// estimate carries the bound sqrt(p (1 - p) / N) on its standard error (independent sampling's,
// which stratification never exceeds).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"

namespace penumbra::reference {

// Ray masks: every ray carries one, and only geometry sharing a bit with it is hit.
inline constexpr uint32_t kMaskCamera = 1u;  // camera rays and AO rays
inline constexpr uint32_t kMaskShadow = 2u;  // shadow rays (geometry with castShadows)

// SDF root finding (docs/ACCURACY.md, "SDF objects"): convergence |d| < kSdfTolerance * scale (the
// object's size in its own frame, at least |p|_inf there), brackets bisected to kSdfTolerance * t,
// sphere tracing capped at kSdfMaxIterations per ray and object.
inline constexpr double kSdfTolerance = 1e-12;
inline constexpr uint32_t kSdfMaxIterations = 100000;

struct Hit {
    double t = 0.0;  // ray parameter of the hit
    glm::dvec3 position{0.0};
    glm::dvec3 geometricNormal{0.0};  // unit, as stored (not flipped toward the ray)
    glm::dvec3 shadingNormal{0.0};    // unit: interpolated vertex normal (meshes), exact (analytic)
    int32_t id = -1;
};

// A light as the reference sees it: position (point / sphere), travel direction (directional).
struct ReferenceLight {
    ecs::LightType type = ecs::LightType::Point;
    glm::dvec3 position{0.0};
    glm::dvec3 direction{0.0, -1.0, 0.0};  // unit, the direction the light travels
    double radius = 0.0;                   // sphere lights
    double angularRadius = 0.0;            // directional lights, radians
};

class ReferenceScene {
public:
    // Null with `error` when Embree cannot create a device.
    static std::unique_ptr<ReferenceScene> create(std::string& error);
    ~ReferenceScene();
    ReferenceScene(const ReferenceScene&) = delete;
    ReferenceScene& operator=(const ReferenceScene&) = delete;

    // A triangle mesh placed by `model` (its normals by the inverse transpose). `mask` is a
    // combination of kMaskCamera and kMaskShadow. False with `error` for invalid data.
    bool addMesh(const assets::MeshData& mesh, const glm::dmat4& model, int32_t id, uint32_t mask,
                 std::string& error);
    // Analytic shapes, intersected exactly in double precision (visible to every ray).
    void addSphere(const glm::dvec3& center, double radius, int32_t id);
    // The plane dot(p, normal) = offset (two-sided, infinite); `normal` is normalised here.
    void addPlane(const glm::dvec3& normal, double offset, int32_t id);
    // The zero set of a shape program (its own frame placed by `model`: any invertible affine
    // matrix, non-uniform scale included), found in double precision in the program's frame:
    // sphere tracing on evaluateShapeProgram (never an overestimate) inside the program's bounds
    // until |d| < kSdfTolerance * scale or a sign change, then bisection of the bracket to
    // kSdfTolerance relative in t; the first root along the ray (docs/ACCURACY.md). Normal: the
    // central-difference gradient of the program, by the inverse transpose. The program is copied.
    bool addShapeProgram(const sdf::ShapeProgram& program, const glm::dmat4& model, int32_t id, uint32_t mask,
                         std::string& error);
    // The zero set of a field's trilinear interpolant (sdf::SdfSampler::trilinear between voxel
    // centres, the values as stored) inside the box of voxel centres, placed by `model`: the
    // interpolant is a cubic along the ray in each cell, whose first root is bracketed between the
    // cubic's turning points and bisected to kSdfTolerance relative. A ray entering the box where
    // the interpolant is negative hits the box. The field is copied; every axis needs >= 2 voxels.
    bool addSdfField(const sdf::PsdfAsset& field, const glm::dmat4& model, int32_t id, uint32_t mask,
                     std::string& error);
    void addLight(const ReferenceLight& light);
    // Builds the BVH; call once after the add* calls and before any query.
    bool commit(std::string& error);

    const std::vector<ReferenceLight>& lights() const { return m_lights; }

    // Root finding on SDF objects (shape programs, fields) since commit / the last reset: rays
    // tested against an SDF object's bounds, sphere-tracing iterations, and the rays that reached
    // kSdfMaxIterations without converging (counted as misses; report them).
    struct SdfStats {
        uint64_t rays = 0;
        uint64_t iterations = 0;
        uint64_t unconverged = 0;
    };
    SdfStats sdfStats() const;
    void resetSdfStats();
    // Offset of secondary-ray origins along the normal at `p` (docs/ACCURACY.md):
    // 1e-5 * max(|p|_inf, extent of the finite geometry's bounds).
    double rayOffset(const glm::dvec3& p) const;

    // Nearest hit with t in (tMin, tMax) along origin + t * dir (dir need not be unit).
    bool intersect(const glm::dvec3& origin, const glm::dvec3& dir, double tMin, double tMax, uint32_t mask,
                   Hit& hit) const;
    // Any hit with t in (tMin, tMax).
    bool occluded(const glm::dvec3& origin, const glm::dvec3& dir, double tMin, double tMax,
                  uint32_t mask) const;

private:
    ReferenceScene();
    struct Impl;
    std::unique_ptr<Impl> m_impl;
    std::vector<ReferenceLight> m_lights;
};

// Meshes of the visible MeshRenderers (id = entity index; kMaskShadow only with castShadows) and the
// lights with castShadows, both in ascending entity index. Transforms must be up to date.
// Visible SdfRenderers (with an `sdf` asset; ids and masks as meshes) from their original geometry:
//   Shapes    the ShapeProgram asset, exactly (addShapeProgram);
//   MeshBake  the mesh file `bakeMesh` as a triangle mesh (the asset manager's copy when it still
//             holds that file's mesh, otherwise read with assets::loadMesh + generateNormals);
//             without a path (a baked in-memory mesh) the baked field's interpolant, logged;
//   Field     a .psdf has no original geometry: its own trilinear interpolant (addSdfField).
bool buildFromWorld(const ecs::World& world, const assets::AssetManager& assets, ReferenceScene& scene,
                    std::string& error);

// The camera of renderer/scene_renderer.cpp (setupCamera), in double precision: an orthonormal basis
// from the camera's world matrix without scale; the ray through pixel (x, y) is
// forward + ndc.x * rayRight + ndc.y * rayUp, ndc = (pixel + 0.5) / size * 2 - 1 (row 0 on top), so
// its parameter t is the linear view depth. Hits count only for near <= t <= far.
struct ReferenceCamera {
    glm::dvec3 eye{0.0};
    glm::dvec3 forward{0.0, 0.0, -1.0};
    glm::dvec3 rayRight{1.0, 0.0, 0.0};
    glm::dvec3 rayUp{0.0, -1.0, 0.0};
    double nearPlane = 0.0;
    double farPlane = std::numeric_limits<double>::infinity();
    uint32_t width = 0;
    uint32_t height = 0;

    glm::dvec3 pixelRay(double x, double y) const;  // x, y: pixel-centre coordinates (+0.5)
};

// From an ECS camera (fovY, near, far, Transform::worldMatrix). False with `error` as the
// rasterizer would refuse it.
bool makeCamera(const ecs::World& world, ecs::Entity camera, uint32_t width, uint32_t height,
                ReferenceCamera& out, std::string& error);
// From a position, a target and an up vector (tests).
ReferenceCamera lookAtCamera(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up,
                             double fovY, uint32_t width, uint32_t height);

// A Monte Carlo estimate and the bound on its standard error.
struct Estimate {
    double value = 0.0;
    double stdError = 0.0;
    uint32_t samples = 0;
};

// The per-pixel seed of the random streams (splitmix64 of the inputs).
uint64_t pixelSeed(uint64_t seed, uint32_t x, uint32_t y, uint32_t stream);

// Rounds a requested sample count up to the next k * k (k >= 1).
uint32_t stratifiedCount(uint32_t samples);
// The smallest k * k whose worst-case standard-error bound sqrt(1/4 / N) is at most error / 3: the
// sample count for measuring errors of size `error` with the reference's noise 3x smaller.
// 0 when error is not > 0 or needs more than 2^24 samples.
uint32_t samplesForError(double error);

// Cosine-weighted AO at `point` over the hemisphere of the unit `normal` (rays start at
// point + normal * rayOffset): the fraction of rays with no hit closer than `maxDistance`.
Estimate ambientOcclusion(const ReferenceScene& scene, const glm::dvec3& point, const glm::dvec3& normal,
                          uint32_t samples, double maxDistance, uint64_t seed);
// Visible fraction of `light` from `point` (docs/ACCURACY.md): directions below the tangent plane
// of `normal` count as occluded; a point inside a sphere light sees it whole.
Estimate lightVisibility(const ReferenceScene& scene, const ReferenceLight& light, const glm::dvec3& point,
                         const glm::dvec3& normal, uint32_t samples, uint64_t seed);

enum class AovKind : uint8_t { Depth, Normal, Ids, Ao, Shadow };

struct AovRequest {
    AovKind kind = AovKind::Depth;
    uint32_t light = 0;        // Shadow: index into ReferenceScene::lights()
    std::string name() const;  // depth, normal, ids, ao, shadow, shadow1, ...
};

// Parses "depth,normal,ids,ao,shadow,shadow2"; false with `error` naming the bad entry.
bool parseAovList(const std::string& list, std::vector<AovRequest>& out, std::string& error);

struct RenderDesc {
    std::vector<AovRequest> aovs;
    uint32_t samples = 1024;     // AO and area-light rays per pixel (rounded up to k * k)
    double aoMaxDistance = 1.0;  // scene units; infinity = unbounded
    uint64_t seed = 1;
    uint32_t threads = 0;                  // 0: std::thread::hardware_concurrency()
    std::function<void(double)> progress;  // fraction done, called from worker threads
};

struct AovImage {
    std::string name;
    uint32_t width = 0, height = 0, channels = 1;
    std::vector<float> data;    // width * height * channels, row 0 = top
    uint32_t samples = 0;       // Monte Carlo samples per pixel (0: exact)
    double meanStdError = 0.0;  // mean of the per-pixel standard-error bounds over hit pixels
    double maxStdError = 0.0;
};

// Renders every requested AOV. False with `error` for an invalid request (no camera size, a
// shadow AOV for a light the scene does not have, zero samples, a negative AO distance).
bool render(const ReferenceScene& scene, const ReferenceCamera& camera, const RenderDesc& desc,
            std::vector<AovImage>& out, std::string& error);

}  // namespace penumbra::reference
