// The CPU reference renderer's self-checks (tools/reference/reference.h, docs/ACCURACY.md): AO and
// sphere-light visibility against closed forms, exact depth of analytic shapes and of a triangle
// mesh, ray masks, determinism, PFM files and AOV parsing. No GPU.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "reference/pfm.h"
#include "reference/reference.h"

namespace penumbra::test {
namespace {

using namespace penumbra::reference;
constexpr double kPi = 3.14159265358979323846;

std::unique_ptr<ReferenceScene> newScene() {
    std::string error;
    auto s = ReferenceScene::create(error);
    EXPECT_TRUE(s) << error;
    return s;
}

void commit(ReferenceScene& s) {
    std::string error;
    ASSERT_TRUE(s.commit(error)) << error;
}

// Solid angle of a spherical cap of half-angle a.
double capSolidAngle(double a) { return 2.0 * kPi * (1.0 - std::cos(a)); }

// Solid angle of the intersection of two spherical caps of half-angles a, b (<= pi/2) whose axes
// are g apart (Mazonka 2012, "Solid angle of conical surfaces, polyhedral cones, and intersecting
// spherical caps", eq. for two caps):
//   O = 2 [ pi - acos((cos g - cos a cos b) / (sin a sin b))
//              - acos((cos b - cos g cos a) / (sin g sin a)) cos a
//              - acos((cos a - cos g cos b) / (sin g sin b)) cos b ]
// for |a - b| < g < a + b; the smaller cap when one contains the other; 0 when they are apart.
double capIntersection(double a, double b, double g) {
    if (g >= a + b) return 0.0;
    if (g <= std::abs(a - b)) return capSolidAngle(std::min(a, b));
    auto acosc = [](double x) { return std::acos(std::clamp(x, -1.0, 1.0)); };
    const double ca = std::cos(a), cb = std::cos(b), cg = std::cos(g);
    const double sa = std::sin(a), sb = std::sin(b), sg = std::sin(g);
    return 2.0 * (kPi - acosc((cg - ca * cb) / (sa * sb)) - acosc((cb - cg * ca) / (sg * sa)) * ca -
                  acosc((ca - cg * cb) / (sg * sb)) * cb);
}

TEST(ReferenceSelfCheck, SphereOnPlaneAoMatchesClosedForm) {
    // A unit sphere resting on the plane y = 0; unbounded occlusion distance. At a point on the
    // plane x from the contact point the sphere covers the projected solid angle of a cap of
    // sin(alpha) = r / d tilted by cos(beta) = r / d: AO = 1 - r^3 / (x^2 + r^2)^(3/2).
    auto s = newScene();
    const double r = 1.0;
    s->addPlane({0, 1, 0}, 0.0, 0);
    s->addSphere({0, r, 0}, r, 1);
    commit(*s);
    for (double x : {0.25, 0.5, 1.0, 1.5, 2.5, 4.0}) {
        const double exact = 1.0 - r * r * r / std::pow(x * x + r * r, 1.5);
        const Estimate e = ambientOcclusion(*s, {x, 0, 0}, {0, 1, 0}, 4096,
                                            std::numeric_limits<double>::infinity(), 17 + uint64_t(x * 8));
        EXPECT_EQ(e.samples, 4096u);
        std::printf("AO x %.2f: reference %.5f exact %.5f standard error %.5f\n", x, e.value, exact,
                    e.stdError);
        ASSERT_GT(e.stdError, 0.0);
        // Criterion: within 3x the reference's stated standard error (the acceptance).
        EXPECT_LE(std::abs(e.value - exact), 3.0 * e.stdError)
            << "x " << x << ": AO " << e.value << " exact " << exact << " standard error " << e.stdError;
        // Stratification keeps the real error far below the (independent-sampling) bound.
        EXPECT_LE(std::abs(e.value - exact), 0.005) << "x " << x;
    }
    // A bounded distance only counts hits closer than it: at x = 4 nothing is within 1 unit.
    const Estimate near = ambientOcclusion(*s, {4, 0, 0}, {0, 1, 0}, 1024, 1.0, 3);
    EXPECT_EQ(near.value, 1.0);
}

TEST(ReferenceSelfCheck, SphereLightBehindSphereMatchesCapOverlap) {
    // A sphere light of radius 2 at distance 10 straight above a point on the plane; a sphere of
    // radius 0.6 at distance 4 whose direction is g from the light's. Both subtend caps:
    // visible fraction = 1 - |cap(light) ∩ cap(occluder)| / |cap(light)|.
    const glm::dvec3 p(0.0), n(0, 1, 0);
    const double lightDist = 10.0, lightRadius = 2.0, occDist = 4.0, occRadius = 0.6;
    const double a = std::asin(lightRadius / lightDist), b = std::asin(occRadius / occDist);
    for (double g : {0.02, 0.1, 0.2, 0.3, 0.4}) {
        auto s = newScene();
        s->addSphere(occDist * glm::dvec3(std::sin(g), std::cos(g), 0.0), occRadius, 1);
        ReferenceLight light;
        light.type = ecs::LightType::Sphere;
        light.position = {0, lightDist, 0};
        light.radius = lightRadius;
        s->addLight(light);
        commit(*s);
        const double exact = 1.0 - capIntersection(a, b, g) / capSolidAngle(a);
        const Estimate e = lightVisibility(*s, light, p, n, 4096, 99);
        std::printf("sphere light g %.2f: visible %.5f exact %.5f standard error %.5f\n", g, e.value, exact,
                    e.stdError);
        // Criterion: within the stated standard error (1x), and never off by more than 0.005.
        EXPECT_LE(std::abs(e.value - exact), std::max(e.stdError, 1e-12))
            << "g " << g << ": visible " << e.value << " exact " << exact << " standard error " << e.stdError;
        EXPECT_LE(std::abs(e.value - exact), 0.005) << "g " << g;
        // The same caps for a directional light of angular radius a (its cone toward +Y): the
        // occluder hides the same directions, so the same closed form holds.
        ReferenceLight sun;
        sun.type = ecs::LightType::Directional;
        sun.direction = {0, -1, 0};
        sun.angularRadius = a;
        const Estimate d = lightVisibility(*s, sun, p, n, 4096, 7);
        std::printf("directional light g %.2f: visible %.5f exact %.5f standard error %.5f\n", g, d.value,
                    exact, d.stdError);
        EXPECT_LE(std::abs(d.value - exact), std::max(d.stdError, 1e-12)) << "directional, g " << g;
    }
}

TEST(ReferenceSelfCheck, HardLightsAndHorizon) {
    auto s = newScene();
    s->addSphere({0, 2, 0}, 0.5, 1);
    commit(*s);
    ReferenceLight point;
    point.type = ecs::LightType::Point;
    point.position = {0, 4, 0};
    // Criterion: a point light is binary: hidden behind the sphere (0), visible beside it (1).
    EXPECT_EQ(lightVisibility(*s, point, {0, 0, 0}, {0, 1, 0}, 64, 1).value, 0.0);
    EXPECT_EQ(lightVisibility(*s, point, {3, 0, 0}, {0, 1, 0}, 64, 1).value, 1.0);
    // A light below the tangent plane is occluded by the surface itself.
    EXPECT_EQ(lightVisibility(*s, point, {3, 0, 0}, {0, -1, 0}, 64, 1).value, 0.0);
    // A directional light with an angular radius, unobstructed: fully visible; straight down onto
    // the sphere's shadow centre: fully hidden (the sphere's cap, 14.5 deg, covers the 2 deg disk).
    ReferenceLight sun;
    sun.type = ecs::LightType::Directional;
    sun.direction = {0, -1, 0};
    sun.angularRadius = 2.0 * kPi / 180.0;
    EXPECT_EQ(lightVisibility(*s, sun, {5, 0, 0}, {0, 1, 0}, 256, 1).value, 1.0);
    EXPECT_EQ(lightVisibility(*s, sun, {0, 0, 0}, {0, 1, 0}, 256, 1).value, 0.0);
}

// Independent pixel ray: tan(fov / 2), the aspect ratio and the camera basis; row 0 on top; the
// ray's component along the view direction is 1, so t is the linear depth.
glm::dvec3 testRay(const glm::dvec3& eye, const glm::dvec3& target, double fovY, uint32_t x, uint32_t y,
                   uint32_t w, uint32_t h) {
    const glm::dvec3 f = glm::normalize(target - eye);
    const glm::dvec3 r = glm::normalize(glm::cross(f, glm::dvec3(0, 1, 0)));
    const glm::dvec3 u = glm::cross(r, f);
    const double t = std::tan(fovY / 2), aspect = double(w) / h;
    const double nx = (x + 0.5) / w * 2 - 1, ny = (y + 0.5) / h * 2 - 1;
    return f + r * (nx * t * aspect) - u * (ny * t);
}

TEST(ReferenceSelfCheck, AnalyticDepthNormalAndIdsAreExact) {
    const glm::dvec3 eye(0.3, 1.7, 5.0), target(0, 0.5, 0);
    const double fov = 50.0 * kPi / 180.0;
    const uint32_t w = 64, h = 48;
    struct S {
        glm::dvec3 c;
        double r;
        int32_t id;
    };
    const S spheres[] = {{{0, 1, 0}, 1.0, 3}, {{1.5, 0.5, -1}, 0.5, 4}};
    auto s = newScene();
    s->addPlane({0, 1, 0}, 0.0, 7);
    for (const S& sp : spheres) s->addSphere(sp.c, sp.r, sp.id);
    commit(*s);
    RenderDesc desc;
    std::string error;
    ASSERT_TRUE(parseAovList("depth,normal,ids", desc.aovs, error)) << error;
    const ReferenceCamera cam = lookAtCamera(eye, target, {0, 1, 0}, fov, w, h);
    std::vector<AovImage> images;
    ASSERT_TRUE(render(*s, cam, desc, images, error)) << error;
    ASSERT_EQ(images.size(), 3u);
    size_t hits = 0, misses = 0;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const glm::dvec3 d = testRay(eye, target, fov, x, y, w, h);
            double best = std::numeric_limits<double>::infinity();
            glm::dvec3 normal(0.0);
            int32_t id = -1;
            if (d.y < 0) {
                best = -eye.y / d.y;
                normal = {0, 1, 0};
                id = 7;
            }
            for (const S& sp : spheres) {
                // Geometric form on the unit direction, then back to depth units.
                const double len = glm::length(d);
                const glm::dvec3 u = d / len, oc = sp.c - eye;
                const double tc = glm::dot(oc, u), d2 = glm::dot(oc, oc) - tc * tc;
                if (d2 > sp.r * sp.r) continue;
                const double t = (tc - std::sqrt(sp.r * sp.r - d2)) / len;
                if (t > 0 && t < best) {
                    best = t;
                    normal = (eye + t * d - sp.c) / sp.r;
                    id = sp.id;
                }
            }
            const size_t i = size_t(y) * w + x;
            if (!std::isfinite(best)) {
                ++misses;
                EXPECT_EQ(images[0].data[i], 0.0f);
                EXPECT_EQ(images[2].data[i], -1.0f);
                continue;
            }
            ++hits;
            // Criterion: depth exact to 1e-6 relative (the stored value is a float: 6e-8).
            EXPECT_LE(std::abs(images[0].data[i] - best), 1e-6 * best) << x << "," << y;
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(images[1].data[i * 3 + c], normal[c], 1e-6);
            EXPECT_EQ(images[2].data[i], float(id));
        }
    EXPECT_GT(hits, size_t(w * h / 2));
    EXPECT_GT(misses, 0u);  // the sky above the horizon
}

TEST(ReferenceSelfCheck, MeshDepthIsExactAndMasksApply) {
    // A quad (two triangles) in the local XY plane, rotated and moved so it lies in z = -3 facing
    // +Z; the camera at the origin looks down -Z: every pixel sees it at depth 3 exactly.
    assets::MeshData quad;
    quad.positions = {{-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}};
    quad.normals.assign(4, glm::vec3(0, 0, 1));
    quad.indices = {0, 1, 2, 0, 2, 3};
    glm::dmat4 model = glm::translate(glm::dmat4(1.0), glm::dvec3(0.25, -0.5, -3.0));
    model = glm::rotate(model, 0.7, glm::dvec3(0, 0, 1));  // in-plane: depth unchanged
    auto s = newScene();
    std::string error;
    ASSERT_TRUE(s->addMesh(quad, model, 42, kMaskCamera | kMaskShadow, error)) << error;
    // A second quad that only casts shadows (kMaskShadow): camera rays must pass through it.
    glm::dmat4 blocker = glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, -1.0));
    ASSERT_TRUE(s->addMesh(quad, blocker, 43, kMaskShadow, error)) << error;
    commit(*s);
    const ReferenceCamera cam = lookAtCamera({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 1.0, 40, 30);
    RenderDesc desc;
    ASSERT_TRUE(parseAovList("depth,ids,normal", desc.aovs, error)) << error;
    std::vector<AovImage> images;
    ASSERT_TRUE(render(*s, cam, desc, images, error)) << error;
    for (size_t i = 0; i < size_t(40 * 30); ++i) {
        // Criterion: mesh depth exact to 1e-6 relative; the shadow-only quad is invisible.
        EXPECT_LE(std::abs(images[0].data[i] - 3.0), 3e-6) << i;
        EXPECT_EQ(images[1].data[i], 42.0f);
        EXPECT_NEAR(images[2].data[i * 3 + 2], 1.0, 1e-6);
    }
    // Shadow rays see the blocker.
    EXPECT_TRUE(s->occluded({0, 0, -2}, {0, 0, 1}, 0.0, 10.0, kMaskShadow));
    EXPECT_FALSE(s->occluded({0, 0, -2}, {0, 0, 1}, 0.0, 10.0, kMaskCamera));
}

TEST(ReferenceRender, DeterministicWhateverTheThreadCount) {
    auto s = newScene();
    s->addPlane({0, 1, 0}, 0.0, 0);
    s->addSphere({0, 1, 0}, 1.0, 1);
    ReferenceLight light;
    light.type = ecs::LightType::Sphere;
    light.position = {2, 4, 1};
    light.radius = 0.5;
    s->addLight(light);
    commit(*s);
    const ReferenceCamera cam = lookAtCamera({0, 2, 5}, {0, 0.5, 0}, {0, 1, 0}, 0.9, 48, 32);
    RenderDesc desc;
    std::string error;
    ASSERT_TRUE(parseAovList("ao,shadow", desc.aovs, error)) << error;
    desc.samples = 60;  // rounded up to 64
    desc.aoMaxDistance = 2.0;
    std::vector<AovImage> one, two;
    desc.threads = 1;
    ASSERT_TRUE(render(*s, cam, desc, one, error)) << error;
    desc.threads = 2;
    ASSERT_TRUE(render(*s, cam, desc, two, error)) << error;
    ASSERT_EQ(one.size(), 2u);
    EXPECT_EQ(one[0].samples, 64u);
    for (size_t a = 0; a < 2; ++a) {
        // Criterion: bit-identical images (per-pixel seeds), the same standard error.
        EXPECT_EQ(one[a].data, two[a].data) << one[a].name;
        EXPECT_EQ(one[a].meanStdError, two[a].meanStdError);
        EXPECT_GT(one[a].meanStdError, 0.0);
        EXPECT_LE(one[a].maxStdError, 0.5 / 8.0);  // sqrt(1/4 / 64)
    }
    // A shadow AOV for a light the scene does not have is refused.
    ASSERT_TRUE(parseAovList("shadow1", desc.aovs, error));
    EXPECT_FALSE(render(*s, cam, desc, one, error));
    EXPECT_NE(error.find("shadow1"), std::string::npos) << error;
}

TEST(ReferenceRender, SamplesForError) {
    // Criterion: N = k^2 with 0.5 / k <= E / 3 and k minimal: E = 0.02 -> k = 75, N = 5625.
    EXPECT_EQ(samplesForError(0.02), 5625u);
    EXPECT_EQ(samplesForError(0.05), 900u);  // k = 30
    EXPECT_EQ(samplesForError(1.5), 1u);
    EXPECT_EQ(samplesForError(0.0), 0u);
    EXPECT_EQ(samplesForError(1e-6), 0u);  // more than 2^24 samples
    EXPECT_EQ(stratifiedCount(1000), 1024u);
    EXPECT_EQ(stratifiedCount(1024), 1024u);
    EXPECT_EQ(stratifiedCount(1), 1u);
    for (double e : {0.02, 0.05, 0.1}) {
        const uint32_t n = samplesForError(e);
        EXPECT_LE(0.5 / std::sqrt(double(n)), e / 3.0 + 1e-15);
        const uint32_t k = uint32_t(std::lround(std::sqrt(double(n))));
        EXPECT_GT(0.5 / double(k - 1), e / 3.0);  // one fewer per side would not do
    }
}

TEST(ReferenceRender, AovListParsing) {
    std::vector<AovRequest> aovs;
    std::string error;
    ASSERT_TRUE(parseAovList("depth,normal,ids,ao,shadow,shadow3", aovs, error)) << error;
    ASSERT_EQ(aovs.size(), 6u);
    EXPECT_EQ(aovs[5].light, 3u);
    EXPECT_EQ(aovs[5].name(), "shadow3");
    EXPECT_EQ(aovs[4].name(), "shadow");
    EXPECT_FALSE(parseAovList("depth,colour", aovs, error));
    EXPECT_NE(error.find("colour"), std::string::npos);
    EXPECT_FALSE(parseAovList("depth,depth", aovs, error));
    EXPECT_FALSE(parseAovList("shadowx", aovs, error));
    EXPECT_FALSE(parseAovList("", aovs, error));
}

TEST(ReferencePfm, RoundTripAndBottomToTopRows) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "penumbra_reference_pfm_test";
    std::filesystem::create_directories(dir);
    FloatImage img;
    img.width = 3;
    img.height = 2;
    img.channels = 1;
    img.data = {1, 2, 3, 4, 5, 6};  // top row 1 2 3, bottom row 4 5 6
    std::string error;
    const std::string path = (dir / "g.pfm").string();
    ASSERT_TRUE(writePfm(path, img, error)) << error;
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string header = "Pf\n3 2\n-1.0\n";
    ASSERT_EQ(bytes.size(), header.size() + 6 * 4);
    EXPECT_EQ(bytes.substr(0, header.size()), header);
    float first;
    std::memcpy(&first, bytes.data() + header.size(), 4);
    EXPECT_EQ(first, 4.0f);  // the file starts with the bottom row (little-endian on this machine)
    FloatImage back;
    ASSERT_TRUE(readPfm(path, back, error)) << error;
    EXPECT_EQ(back.data, img.data);
    FloatImage rgb{2, 1, 3, {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f}};
    ASSERT_TRUE(writePfm(path, rgb, error)) << error;
    ASSERT_TRUE(readPfm(path, back, error)) << error;
    EXPECT_EQ(back.channels, 3u);
    EXPECT_EQ(back.data, rgb.data);
    // Truncated data is refused with the reason.
    std::filesystem::resize_file(path, std::filesystem::file_size(path) - 4);
    EXPECT_FALSE(readPfm(path, back, error));
    EXPECT_NE(error.find("truncated"), std::string::npos) << error;
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace penumbra::test
