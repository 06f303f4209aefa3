// Hard cases of the SDF trace on analytic shapes (issue 11 item 4), each on both backends under
// validation, against an exact double-precision CPU ray cast (stability_util.h):
//   1  grazing rays along a plane and along a wall
//   2b an analytic wall of half-thickness 1e-3
//   4  objects near coordinate 1e5
//   5  camera inside an object; camera 1e-4 outside its surface
//   6b two analytic spheres 1e-4 apart
//   7  rays passing within epsilon of silhouettes: step-limit artefacts per quality preset
//   10 the same scene at 1e-3, 1 and 1e4 units
//   12 non-uniform / zero / negative scale and NaN translation on SDF objects
//   13 a near miss beside a grazing plane: a far root must not hide a nearer surface
//   14 a crowd of 48 boxes and spheres, with and without culling
// Error measures (the trace's own stopping rule, renderer/shaders/sdf_trace.comp): a hit is accepted
// when the distance is below hitEpsilon pixel footprints (fp * t, fp = 2 tan(fov/2) / height), or 4x
// that when the step limit ran out. So the traced point lies within 4 * hitEpsilon * fp * t of the
// surface ("perpendicular error"), and the depth error along a ray meeting the surface at angle
// theta (cos = |n . ray|) is that divided by cos: relative to the distance, 4 * hitEpsilon * fp / cos.
// Criteria below are stated in these terms next to each assertion.
#include "stability/stability_util.h"

#include "engine/assets/primitives.h"
#include "support/golden.h"

namespace penumbra::test::stability {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
using scene::TraceQuality;
using sdf::ShapeNode;

class Stability : public GpuTest {
protected:
    rhi::Backend backend() const { return GetParam(); }
};

// Per-pixel comparison of a traced G-buffer against an exact hit function.
struct DepthStats {
    size_t refHits = 0, traceHits = 0, both = 0, holes = 0, extra = 0;
    size_t overBound = 0;  // perpendicular error above the stated bound
    size_t behind = 0;     // traced point behind the exact surface by more than float slack
    size_t wrongId = 0;
    double maxPerpFootprints = 0;  // perpendicular error / (fp * t)
    std::vector<double> rel;       // |ds| / s on pixels hit in both
    double holeShare() const { return refHits ? double(holes) / double(refHits) : 0.0; }
};

// `exact(o, d)` returns the exact first hit along o + s d (s = linear depth) with its id; pixels whose
// exact depth lies beyond `farCut` count neither as reference hits nor as holes. `boundFootprints`:
// the stated bound of the perpendicular error in pixel footprints; `absSlack`: extra absolute error
// allowed for float precision (scene units).
template <typename Exact>
DepthStats compareDepth(const GBuffer& g, const RefCamera& cam, Exact exact, double boundFootprints,
                        double absSlack, double farCut) {
    DepthStats st;
    const double fp = cam.footprint();
    for (uint32_t y = 0; y < g.h; ++y)
        for (uint32_t x = 0; x < g.w; ++x) {
            const size_t i = g.at(x, y);
            const glm::dvec3 d = cam.dir(x, y);
            const Hit h = exact(cam.eye, d);
            const bool refHit = h.s < kInf && h.s <= farCut;
            const bool traced = g.hit(i);
            st.traceHits += traced;
            if (refHit) ++st.refHits;
            if (refHit && !traced) ++st.holes;
            if (!refHit && traced && h.s == kInf) ++st.extra;
            if (!refHit || !traced) continue;
            ++st.both;
            if (h.id >= 0 && g.id(i) != h.id) ++st.wrongId;
            const double len = glm::length(d);
            const double cosT = std::max(std::abs(glm::dot(h.n, d / len)), 1e-12);
            const double ds = double(g.depth[i]) - h.s;
            const double t = h.s * len;
            const double perp = std::abs(ds) * len * cosT;
            st.maxPerpFootprints = std::max(st.maxPerpFootprints, perp / (fp * t));
            if (perp > boundFootprints * fp * t + absSlack + 1e-5 * t) ++st.overBound;
            if (ds * len * cosT > absSlack + 1e-5 * t) ++st.behind;
            st.rel.push_back(std::abs(ds) / h.s);
        }
    return st;
}

double presetEps(TraceQuality q) { return double(scene::tracePreset(q).hitEpsilon); }

// ---- 1. grazing rays -----------------------------------------------------------------------------------

// Along a plane (camera 0.05 above y = 0, looking horizontally) and along a wall (the face x = 0.3 of
// a long box, camera looking parallel to it). Rows next to the horizon meet the plane at a fraction
// of a pixel's angle: the depth error along the ray is up to 4 * hitEpsilon * fp / cos(theta) of the
// distance by the stopping rule (e.g. ~50 % of the distance on the row next to the horizon at
// "medium"), so the criterion is the perpendicular one, not a flat relative error.
// Criteria: (a) perpendicular error <= 4 * hitEpsilon footprints + 1e-5 t (every hit pixel);
// (b) no traced point behind the exact surface (> 1e-5 t); (c) holes (exact hit nearer than 0.9 far,
// traced miss) <= 0.5 % of the exact-hit pixels. Presets medium and reference.
// Shadows (one more frame per geometry at "medium", shadows at resolutionScale 1, hard suns of angular
// radius 0, one layer each): the plane gets a wall 0.03 high (the box x in [0.3, 0.4], y in
// [-0.03, 0.03], z in [-100, 0]) and suns behind it (toward +x) at elevations 3 and 10 degrees, whose
// shadow rays graze the plane;
// the wall gets a floor y = -0.3 and suns behind it at 2 and 10 degrees from its face (toward
// (sin a, 0.6 cos a, -0.8 cos a)), whose shadow rays run along the wall. On the receiver's pixels
// (the plane / the floor) the exact visibility is the segment from the traced point toward the sun
// against the box (stability_util.h segmentBoxClearance: lit when it clears the box); as in case 09
// pixels whose segment clears the box, or enters it, by at most 2 pixel footprints are not counted,
// nor pixels traced at the near plane (the plane's bottom rows: rays starting under the plane). Each
// frame at the preset's shadow step limit (medium: 64) and at 1024. Criteria: no lit receiver
// shadowed, no shadowed receiver lit, except the wall at 2 degrees with 64 steps: a known limit (step
// exhaustion near the wall), light leaking on at most 45 % of its shadowed pixels (measured 40 %).
// Measured 2026-12-02 otherwise (both backends): 0 leaking, 0 wrongly shadowed in every frame.
TEST_P(Stability, Case01_GrazingRaysAlongAPlaneAndAWall) {
    constexpr uint32_t w = 128, h = 96;
    for (int wall = 0; wall < 2; ++wall) {
        StabScene s({0, wall ? 0.0f : 0.05f, 0}, {0, wall ? 0.0f : 0.05f, -1}, 0.1f, 100.0f);
        const glm::dvec3 boxC(0.35, 0.0, -50.0), boxE(0.05, 5.0, 50.0);
        const ecs::Entity e = wall ? s.shape(ShapeNode::box(boxE), glm::vec3(boxC))
                                   : s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
        ecs::updateTransforms(s.world);
        SceneRenderer r(dev());
        for (TraceQuality q : {TraceQuality::Medium, TraceQuality::Reference}) {
            GBuffer g;
            ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h, q), g));
            const RefCamera cam(s.world, s.camera, w, h);
            auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
                Hit hh = wall ? rayBox(o, d, boxC, boxE, cam.nearPlane)
                              : rayPlane(o, d, {0, 1, 0}, 0.0, cam.nearPlane);
                hh.id = int(e.index);
                return hh;
            };
            const double bound = 4.0 * presetEps(q);
            const DepthStats st = compareDepth(g, cam, exact, bound, 0.0, 0.9 * cam.farPlane);
            const Sanity san = checkSanity(g, 0.1f, 100.0f);
            summary(wall ? "01 grazing wall" : "01 grazing plane", backend(),
                    "%s: %zu exact-hit px, holes %.3f %% (<= 0.5 %%), perp. error max %.3f fp (<= %.2f), "
                    "%zu over, %zu behind (0), rel. depth error p50 %.2e p99 %.2e max %.2e, wrong id %zu",
                    scene::toString(q), st.refHits, 100 * st.holeShare(), st.maxPerpFootprints, bound,
                    st.overBound, st.behind, quantile(st.rel, 0.5), quantile(st.rel, 0.99),
                    quantile(st.rel, 1.0), st.wrongId);
            EXPECT_TRUE(san.ok()) << san.nonFinite << " non-finite, " << san.outOfRange << " out of range";
            EXPECT_GT(st.refHits, size_t(w) * h / 4);
            EXPECT_LE(st.holeShare(), 0.005) << "holes / exact-hit pixels";
            EXPECT_EQ(st.overBound, 0u) << "perpendicular error above 4 * hitEpsilon footprints";
            EXPECT_EQ(st.behind, 0u) << "traced points behind the exact surface";
            EXPECT_EQ(st.wrongId, 0u);
        }

        // Shadows: a light behind the wall, its rays grazing the plane / the wall.
        const glm::dvec3 occC = wall ? boxC : glm::dvec3(0.35, 0.0, -50.0);
        const glm::dvec3 occE = wall ? boxE : glm::dvec3(0.05, 0.03, 50.0);
        const ecs::Entity receiver = wall ? s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.3f, 0}) : e;
        if (!wall) s.shape(ShapeNode::box(occE), glm::vec3(occC));
        const double angles[2] = {wall ? 2.0 : 3.0, 10.0};
        ecs::Entity suns[2];
        for (int k = 0; k < 2; ++k) {
            const double a = glm::radians(angles[k]);
            suns[k] = directionalLight(s,
                                       wall ? glm::dvec3(std::sin(a), 0.6 * std::cos(a), -0.8 * std::cos(a))
                                            : glm::dvec3(std::cos(a), std::sin(a), 0.0),
                                       0.0f);
        }
        for (uint32_t steps : {0u, 1024u}) {  // the preset's shadow step limit (medium: 64), 1024
            FrameDesc fd = s.frame(w, h);
            fd.settings.shadows.resolutionScale = 1.0f;
            fd.settings.shadows.maxSteps = steps;
            GBuffer sg;
            ASSERT_TRUE(renderAndRead(s, r, fd, sg));
            ShadowStrip strip;
            ASSERT_TRUE(readShadow(r, w, h, 2, strip));
            const RefCamera cam(s.world, s.camera, w, h);
            for (uint32_t k = 0; k < 2; ++k) {
                const glm::dvec3 l = towardLight(s, suns[k]);
                size_t compared = 0, shadowed = 0, leaks = 0, dark = 0, band = 0;
                for (uint32_t y = 0; y < h; ++y)
                    for (uint32_t x = 0; x < w; ++x) {
                        const size_t i = sg.at(x, y);
                        if (!sg.hit(i) || sg.id(i) != int(receiver.index) || nearPlaneHit(sg, cam, i))
                            continue;
                        const glm::dvec3 d = cam.dir(x, y);
                        const glm::dvec3 p = cam.eye + d * double(sg.depth[i]);
                        const double margin = 2.0 * cam.footprint() * double(sg.depth[i]) * glm::length(d);
                        const double clearance = segmentBoxClearance(p, l, 0.0, cam.farPlane, occC, occE);
                        if (std::abs(clearance) <= margin) {
                            ++band;
                            continue;
                        }
                        const bool lit = clearance > 0.0;
                        const bool gpuLit = strip.at(k, x, y) > 0.5;
                        ++compared;
                        shadowed += !lit;
                        leaks += gpuLit && !lit;
                        dark += !gpuLit && lit;
                    }
                summary(wall ? "01 grazing wall" : "01 grazing plane", backend(),
                        "shadow, hard sun %2.0f deg %s, %4u steps: %zu receiver px compared (%zu shadowed, "
                        "%zu in the 2 fp band), light leaking %zu (0), wrongly shadowed %zu (0)",
                        angles[k], wall ? "from the wall" : "above the plane", steps ? steps : 64u, compared,
                        shadowed, band, leaks, dark);
                EXPECT_GT(compared, size_t(w) * h / 8);
                EXPECT_GT(shadowed, size_t(100));
                EXPECT_GT(compared - shadowed, size_t(100));  // both outcomes are compared
                EXPECT_EQ(dark, 0u) << angles[k] << " deg: lit receivers shadowed";
                if (wall && k == 0 && steps == 0) {
                    // Known limit (measured 2026-12-02, both backends: 404 of 1013 shadowed pixels lit, 0
                    // with 1024 steps; 849 before sdf_cone.glsl took a hard ray that runs out of steps
                    // within 4 epsilons of a surface as blocked): a hard ray meeting the wall at 2 degrees
                    // sphere-traces toward it in steps shrinking by (1 - sin 2deg) and may run out of the
                    // preset's 64 steps farther than that. Criterion: the measured leak, rounded up (a
                    // regression shows; a fix passes).
                    EXPECT_LE(double(leaks), 0.45 * double(shadowed)) << "grazing leak at 64 steps grew";
                } else {
                    EXPECT_EQ(leaks, 0u) << angles[k] << " deg, " << (steps ? steps : 64u)
                                         << " steps: light leaking past the wall";
                }
            }
        }
    }
}

// ---- 2b. analytic thin wall ------------------------------------------------------------------------------

// A box 2 x 2 x 0.002 (half-thickness 1e-3, ~1/20 of a pixel footprint at its distance) at z = -2,
// face-on and turned 60 degrees about Y. Criterion: every pixel whose exact ray hits the wall and
// whose 8 neighbours' rays do too (interior) is traced as a hit of the wall: 100 %; the perpendicular
// error of all hits <= 4 * hitEpsilon footprints + 1e-5 t.
// Shadows (one more frame per angle, shadows at resolutionScale 1): a floor y = -0.9 in front of the
// wall (the wall reaches 0.1 below it), two suns behind the wall 45 degrees up (toward (0, 1, -1)),
// hard (angular radius 0) and soft (0.5 degrees), the camera raised to (0, 1, 0.5) to see the floor.
// Light leaking through the wall is the visibility on the floor's umbra pixels (stability_util.h
// wallShadow: the whole light disc hidden by the exact wall, 2 pixel footprints of margin).
// Criteria: hard sun: umbra mean visibility <= 0.01 and no umbra pixel over 0.5; soft sun: umbra
// mean <= 0.65, the measured leak (known limits of the cone estimate, stated at the assertion); both:
// lit floor pixels darker than 0.5 <= 1 % (the check sees both outcomes).
TEST_P(Stability, Case02b_AnalyticWallHalfThickness1em3) {
    constexpr uint32_t w = 128, h = 96;
    for (float angle : {0.0f, 60.0f}) {
        StabScene s;
        const glm::dvec3 half(1.0, 1.0, 1e-3);
        const glm::quat rot = glm::angleAxis(glm::radians(angle), glm::vec3(0, 1, 0));
        const ecs::Entity e = s.shape(ShapeNode::box(half), {0, 0, -2}, rot);
        ecs::updateTransforms(s.world);
        SceneRenderer r(dev());
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), g));
        const RefCamera cam(s.world, s.camera, w, h);
        const glm::dmat4 model(s.world.get<ecs::Transform>(e)->worldMatrix);
        const glm::dmat4 inv = glm::inverse(model);
        auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
            const glm::dvec3 lo(inv * glm::dvec4(o, 1.0)), ld(glm::dmat3(inv) * d);
            Hit hh = rayBox(lo, ld, glm::dvec3(0.0), half, cam.nearPlane);
            if (hh.s != kInf) hh.n = glm::normalize(glm::dmat3(model) * hh.n);
            hh.id = int(e.index);
            return hh;
        };
        const DepthStats st = compareDepth(g, cam, exact, 4.0 * presetEps(TraceQuality::Medium), 0.0, kInf);
        size_t interior = 0, interiorHit = 0;
        for (uint32_t y = 1; y + 1 < h; ++y)
            for (uint32_t x = 1; x + 1 < w; ++x) {
                bool all = true;
                for (int dy = -1; dy <= 1 && all; ++dy)
                    for (int dx = -1; dx <= 1 && all; ++dx)
                        all = exact(cam.eye, cam.dir(x + dx, y + dy)).s != kInf;
                if (!all) continue;
                ++interior;
                interiorHit += g.hit(g.at(x, y)) && g.id(g.at(x, y)) == int(e.index);
            }
        const double rate = interior ? double(interiorHit) / double(interior) : 0.0;
        summary(
            "02b thin analytic wall", backend(),
            "%.0f deg: interior hit rate %.4f %% of %zu px (= 100 %%), all exact-hit px: holes %zu of %zu, "
            "perp. error max %.3f fp (<= 2), %zu over",
            double(angle), 100 * rate, interior, st.holes, st.refHits, st.maxPerpFootprints, st.overBound);
        EXPECT_GT(interior, size_t(500));
        EXPECT_EQ(interiorHit, interior) << "interior wall pixels traced through the wall";
        EXPECT_EQ(st.overBound, 0u);

        // Shadows: light behind the wall, receivers on the floor in front of it.
        const ecs::Entity floor = s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.9f, 0});
        const glm::dvec3 toSun = glm::normalize(glm::dvec3(0.0, 1.0, -1.0));
        const float softRadius = glm::radians(0.5f);
        const ecs::Entity suns[2] = {directionalLight(s, toSun, 0.0f),
                                     directionalLight(s, toSun, softRadius)};
        s.placeCamera({0, 1.0f, 0.5f}, {0, -0.9f, -1.5f});
        FrameDesc fd = s.frame(w, h);
        fd.settings.shadows.resolutionScale = 1.0f;
        GBuffer sg;
        ASSERT_TRUE(renderAndRead(s, r, fd, sg));
        ShadowStrip strip;
        ASSERT_TRUE(readShadow(r, w, h, 2, strip));
        const RefCamera scam(s.world, s.camera, w, h);
        for (uint32_t k = 0; k < 2; ++k) {
            const WallShadowStats ws = wallShadow(sg, scam, int(floor.index), model, half, strip, k,
                                                  towardLight(s, suns[k]), k ? double(softRadius) : 0.0);
            summary(
                "02b thin analytic wall", backend(),
                "%.0f deg shadow, %s sun: umbra %zu px: visibility mean %.4f max %.3f, %zu over 0.5; lit %zu "
                "px: mean %.4f, %zu under 0.5",
                double(angle), k ? "soft 0.5 deg" : "hard", ws.umbra, ws.umbraMean, ws.umbraMax, ws.umbraOver,
                ws.lit, ws.litMean, ws.litDark);
            EXPECT_GT(ws.umbra, size_t(300));
            EXPECT_GT(ws.lit, size_t(100));
            EXPECT_LE(double(ws.litDark), 0.01 * double(ws.lit)) << "lit floor shadowed";
            if (k == 0) {  // measured 2026-12-02: umbra mean 0, max 0 at both angles
                EXPECT_LE(ws.umbraMean, 0.01) << "hard light leaking through the wall";
                EXPECT_EQ(ws.umbraOver, 0u) << "hard light leaking through the wall";
            } else {
                // Known limit (measured 2026-12-02, both backends, alike at 1024 steps: umbra mean
                // 0.565 at 0 deg, 0.505 at 60 deg, max 0.686): the cone estimate lets about half the
                // light through a wall thinner than the cone's cross-section (sdf_cone.glsl). (Before
                // the soft march counted the cone as at least epsilon wide outside occluders, its
                // smallest step, half a pixel footprint, also jumped this 0.002 wall near the apex:
                // mean 0.605, max 1.0.) Criterion: the measured mean, rounded up.
                EXPECT_LE(ws.umbraMean, 0.6) << "soft light leaking through the wall";
            }
        }
    }
}

// ---- 4. objects near 1e5
// -----------------------------------------------------------------------------------

// A unit sphere and the camera 4 units from it, all translated by (1e5, 1e5, 1e5), against the same
// scene at the origin. Float positions near 1e5 are spaced ulp = 2^-7 = 0.0078 apart, so the point
// ro + rd t and its local coordinates carry errors of a few ulps: the achievable perpendicular error
// is the hit epsilon plus ~4 ulp(1e5). Criteria (pixels hit in both exact and traced): perpendicular
// error <= 4 * hitEpsilon footprints + 4 * ulp(1e5) (the "reference" preset, where the hit epsilon
// is 0.01 footprint, isolates the float part; and the default "medium"); silhouette mismatch
// (pixels hit in one only / hit in either) <= 2 % (the issue-10 silhouette value). The relative depth error
// on pixels with cos >= 0.5 is printed for both origins.
TEST_P(Stability, Case04_ObjectsNearCoordinate1e5) {
    constexpr uint32_t w = 128, h = 96;
    const double ulp = std::ldexp(1.0, -7);  // spacing of floats in [65536, 131072)
    for (TraceQuality q : {TraceQuality::Reference, TraceQuality::Medium}) {
        double relAt[2] = {0, 0};
        for (int far = 0; far < 2; ++far) {
            const glm::vec3 origin = far ? glm::vec3(1e5f) : glm::vec3(0.0f);
            StabScene s(origin + glm::vec3(0.3f, 0.2f, 4.0f), origin, 0.1f, 100.0f);
            const ecs::Entity e = s.shape(ShapeNode::sphere(1.0), origin + glm::vec3(0.1f, -0.05f, 0.02f));
            ecs::updateTransforms(s.world);
            SceneRenderer r(dev());
            GBuffer g;
            ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h, q), g));
            const RefCamera cam(s.world, s.camera, w, h);
            const glm::dvec3 c(s.world.get<ecs::Transform>(e)->worldMatrix[3]);
            auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
                Hit hh = raySphere(o, d, c, 1.0, cam.nearPlane);
                hh.id = int(e.index);
                return hh;
            };
            const double slack = far ? 4 * ulp : 0.0;
            const DepthStats st = compareDepth(g, cam, exact, 4.0 * presetEps(q), slack, kInf);
            std::vector<double> relFacing;
            for (uint32_t y = 0; y < h; ++y)
                for (uint32_t x = 0; x < w; ++x) {
                    const glm::dvec3 d = cam.dir(x, y);
                    const Hit hh = exact(cam.eye, d);
                    if (hh.s == kInf || !g.hit(g.at(x, y))) continue;
                    if (std::abs(glm::dot(hh.n, glm::normalize(d))) < 0.5) continue;
                    relFacing.push_back(relErr(g.depth[g.at(x, y)], hh.s));
                }
            const size_t either = st.both + st.holes + st.extra;
            const double mismatch = either ? double(st.holes + st.extra) / double(either) : 0.0;
            relAt[far] = quantile(relFacing, 1.0);
            summary(
                "04 near 1e5", backend(),
                "%s origin %s: perp. error max %.3f fp (bound %.2f fp + %.4f), %zu over; rel. depth error "
                "(cos >= 0.5) p50 %.2e max %.2e; silhouette mismatch %.3f %% (<= 2 %%)",
                scene::toString(q), far ? "1e5" : "0", st.maxPerpFootprints, 4.0 * presetEps(q), slack,
                st.overBound, quantile(relFacing, 0.5), relAt[far], 100 * mismatch);
            EXPECT_TRUE(checkSanity(g, 0.1f, 100.0f).ok());
            if (!far) {
                EXPECT_GT(st.both, size_t(w) * h / 10);  // the framing
            }
            EXPECT_EQ(st.overBound, 0u) << "perpendicular error above the hit epsilon + 4 ulp(1e5)";
            // Measured 2026-12-01 at 1e5 (both backends): mismatch reference 1.62 %, medium 1.49 %. (It
            // failed before the trace floored its hit epsilon at 4 float ulps of the coordinates: a
            // 0.01-footprint threshold, 4.8e-4 here, lies below the float spacing near 1e5, 0.0078.)
            EXPECT_LE(mismatch, 0.02) << scene::toString(q) << (far ? " at 1e5" : " at the origin");
        }
    }
}

// ---- 5. camera inside / just outside ----------------------------------------------------------------------

// (a) Camera inside a sphere of radius 3 (a box inside it too): documented result of the trace (a ray
// that starts inside a solid hits at its first point): every pixel hits at the near plane
// (|depth - near| <= 1e-5 near), with the enclosing sphere's id. (b) Camera 1e-4 outside a unit
// sphere with near = 1e-5, looking at its centre and along its tangent: every pixel sane (finite
// depth, normal, aux; depth 0 or within [near, far]); looking at the centre every exact-hit pixel is
// hit (no hole) with perpendicular error <= 4 * hitEpsilon footprints + 2^-18 |p| (twice the GPU
// evaluator's documented rounding margin at |p| ~ 1);
// along the tangent holes <= 0.5 % of the exact-hit pixels. (c) The same 1e-4 camera with the
// default near plane 0.1 (rays start inside): every pixel hits at the near plane like (a).
TEST_P(Stability, Case05_CameraInsideAndJustOutside) {
    constexpr uint32_t w = 128, h = 96;
    SceneRenderer r(dev());
    {
        StabScene s({0, 0, 0}, {0, 0, -1}, 0.1f, 100.0f);
        const ecs::Entity sphere = s.shape(ShapeNode::sphere(3.0), {0, 0, 0});
        s.shape(ShapeNode::box({0.5, 0.5, 0.5}), {0, 0, -2});
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), g));
        size_t atNear = 0, rightId = 0;
        for (size_t i = 0; i < g.size(); ++i) {
            atNear += g.hit(i) && std::abs(g.depth[i] - 0.1f) <= 1e-6f;
            rightId += g.id(i) == int(sphere.index);
        }
        const Sanity san = checkSanity(g, 0.1f, 100.0f);
        summary("05 camera inside", backend(),
                "%zu of %zu px hit at the near plane (all), %zu with the sphere's id (all), %zu non-finite",
                atNear, g.size(), rightId, san.nonFinite);
        EXPECT_TRUE(san.ok());
        // A ray that starts inside a solid hits where it starts (sdf_trace.comp): all 12288 px.
        EXPECT_EQ(atNear, g.size()) << "camera inside: every pixel hits at the near plane";
        EXPECT_EQ(rightId, g.size());
    }
    for (int view = 0; view < 2; ++view) {
        const glm::vec3 eye(0.0f, 0.0f, 1.0001f);
        StabScene s(eye, view ? eye + glm::vec3(1, 0, 0) : glm::vec3(0.0f), 1e-5f, 100.0f);
        const ecs::Entity e = s.shape(ShapeNode::sphere(1.0), {0, 0, 0});
        ecs::updateTransforms(s.world);
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), g));
        const RefCamera cam(s.world, s.camera, w, h);
        auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
            Hit hh = raySphere(o, d, glm::dvec3(0.0), 1.0, cam.nearPlane);
            hh.id = int(e.index);
            return hh;
        };
        // Float part: the GPU shape evaluator moves every distance towards zero by 16 ulps of the
        // point's magnitude (SHAPE_EVAL_MARGIN, 2^-19 |p|, renderer/shaders/shape_program.glsl), so a
        // hit can stop that much early; twice that margin is allowed (2^-18 at |p| ~ 1, 3.8e-6: ~3 %
        // of the 1e-4 distance on the central pixels).
        const double slack = std::ldexp(1.0, -18) * 1.0001;
        const DepthStats st = compareDepth(g, cam, exact, 4.0 * presetEps(TraceQuality::Medium), slack, kInf);
        const Sanity san = checkSanity(g, 1e-5f, 100.0f);
        summary(
            "05 camera 1e-4 outside", backend(),
            "%s (near 1e-5): %zu exact-hit px, holes %zu (%.3f %%), perp. error max %.3f fp, %zu over bound, "
            "rel. depth error p50 %.2e max %.2e, %zu non-finite, %zu out of range",
            view ? "along the tangent" : "at the centre", st.refHits, st.holes, 100 * st.holeShare(),
            st.maxPerpFootprints, st.overBound, quantile(st.rel, 0.5), quantile(st.rel, 1.0), san.nonFinite,
            san.outOfRange);
        EXPECT_TRUE(san.ok());
        EXPECT_EQ(st.overBound, 0u);
        if (view == 0) {
            EXPECT_EQ(st.holes, 0u);
        } else {
            EXPECT_LE(st.holeShare(), 0.005);
        }
    }
    {
        StabScene s({0, 0, 1.0001f}, {0, 0, 0}, 0.1f, 100.0f);
        s.shape(ShapeNode::sphere(1.0), {0, 0, 0});
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), g));
        size_t atNear = 0;
        for (size_t i = 0; i < g.size(); ++i) atNear += g.hit(i) && std::abs(g.depth[i] - 0.1f) <= 1e-6f;
        summary("05 camera 1e-4 outside", backend(),
                "near 0.1 (rays start inside): %zu of %zu px at the near plane (all)", atNear, g.size());
        EXPECT_TRUE(checkSanity(g, 0.1f, 100.0f).ok());
        EXPECT_EQ(atNear, g.size());
    }
}

// ---- 6b. two spheres 1e-4 apart
// ----------------------------------------------------------------------------

// Two spheres of radius 0.5 whose surfaces are 1e-4 apart (far below a pixel footprint, ~0.036 here).
// Criterion: every hit pixel carries the id of the sphere the exact ray hits, except where the traced
// point also lies within the hit threshold (4 * hitEpsilon footprints) of the other sphere's surface
// (there the trace may legitimately stop on either): such "justified" swaps are counted and printed,
// unjustified wrong ids must be 0; holes 0 on interior pixels (the exact ray and its 8 neighbours hit).
TEST_P(Stability, Case06b_TwoSpheres1em4Apart) {
    constexpr uint32_t w = 160, h = 120;
    StabScene s({0, 0, 0}, {0, 0, -3}, 0.1f, 100.0f);
    const float c = 0.5f + 0.5e-4f;
    const ecs::Entity a = s.shape(ShapeNode::sphere(0.5), {-c, 0, -3});
    const ecs::Entity b = s.shape(ShapeNode::sphere(0.5), {c, 0, -3});
    ecs::updateTransforms(s.world);
    SceneRenderer r(dev());
    GBuffer g;
    ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), g));
    const RefCamera cam(s.world, s.camera, w, h);
    const glm::dvec3 ca(s.world.get<ecs::Transform>(a)->worldMatrix[3]),
        cb(s.world.get<ecs::Transform>(b)->worldMatrix[3]);
    std::printf("  centres %.9f and %.9f: gap %.3e\n", ca.x, cb.x, cb.x - ca.x - 1.0);
    auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
        Hit ha = raySphere(o, d, ca, 0.5, cam.nearPlane), hb = raySphere(o, d, cb, 0.5, cam.nearPlane);
        ha.id = int(a.index);
        hb.id = int(b.index);
        return ha.s <= hb.s ? ha : hb;
    };
    size_t wrong = 0, justified = 0, hits = 0, interiorHoles = 0;
    const double fp = cam.footprint(), eps = 4.0 * presetEps(TraceQuality::Medium);
    for (uint32_t y = 1; y + 1 < h; ++y)
        for (uint32_t x = 1; x + 1 < w; ++x) {
            const size_t i = g.at(x, y);
            const glm::dvec3 d = cam.dir(x, y);
            const Hit hh = exact(cam.eye, d);
            if (hh.s == kInf) continue;
            bool interior = true;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    interior = interior && exact(cam.eye, cam.dir(x + dx, y + dy)).s != kInf;
            if (!g.hit(i)) {
                interiorHoles += interior;
                continue;
            }
            ++hits;
            if (g.id(i) == hh.id) continue;
            const glm::dvec3 p = cam.eye + d * double(g.depth[i]);
            const glm::dvec3& other = g.id(i) == int(a.index) ? ca : cb;
            const double dist = std::abs(glm::length(p - other) - 0.5);
            const double t = double(g.depth[i]) * glm::length(d);
            if (dist <= eps * fp * t + 1e-5 * t)
                ++justified;
            else
                ++wrong;
        }
    summary("06b spheres 1e-4 apart", backend(),
            "%zu hit px: unjustified wrong ids %zu (0), justified swaps within the hit threshold %zu, "
            "interior holes %zu (0)",
            hits, wrong, justified, interiorHoles);
    EXPECT_TRUE(checkSanity(g, 0.1f, 100.0f).ok());
    EXPECT_EQ(wrong, 0u) << "pixels with the other sphere's id, farther than the hit threshold from it";
    EXPECT_EQ(interiorHoles, 0u);
}

// ---- 7. rays within epsilon of silhouettes: step-limit artefacts -----------------------------------------

// A sphere, a rotated box, a torus seen nearly edge-on and a capsule in front of nothing (rays that
// pass a silhouette closely creep along it and then leave the scene). Steps come from gbuffer.aux y;
// a pixel ran out of steps when steps >= the preset's maxSteps. Criterion per preset (low, medium,
// high, reference): step-limit pixels <= 1 % of the silhouette band (pixels whose exact-hit status
// differs from one of their 8 neighbours, and those neighbours) and <= 0.2 % of all pixels.
TEST_P(Stability, Case07_StepLimitArtefactsNearSilhouettes) {
    constexpr uint32_t w = 160, h = 120;
    StabScene s({0, 0.3f, 0}, {0, 0, -4}, 0.1f, 100.0f);
    s.shape(ShapeNode::sphere(0.6), {-1.3f, 0.4f, -4.0f});
    s.shape(ShapeNode::box({0.5, 0.5, 0.5}), {1.3f, 0.3f, -4.5f},
            glm::quat(glm::radians(glm::vec3(30, 40, 10))));
    s.shape(ShapeNode::torus(0.8, 0.15), {0.0f, -0.6f, -4.0f},
            glm::angleAxis(glm::radians(8.0f), glm::vec3(1, 0, 0)));
    s.shape(ShapeNode::capsule(0.2, 0.5), {0.0f, 0.9f, -5.0f},
            glm::angleAxis(glm::radians(70.0f), glm::vec3(0, 0, 1)));
    SceneRenderer r(dev());
    // Silhouette band from a "reference" frame's hit mask (dilated by one pixel).
    GBuffer ref;
    ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h, TraceQuality::Reference), ref));
    std::vector<uint8_t> band(ref.size(), 0);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int xx = int(x) + dx, yy = int(y) + dy;
                    if (xx < 0 || yy < 0 || xx >= int(w) || yy >= int(h)) continue;
                    if (ref.hit(ref.at(x, y)) != ref.hit(ref.at(uint32_t(xx), uint32_t(yy)))) {
                        for (int ey = -1; ey <= 1; ++ey)
                            for (int ex = -1; ex <= 1; ++ex) {
                                const int bx = int(x) + ex, by = int(y) + ey;
                                if (bx >= 0 && by >= 0 && bx < int(w) && by < int(h))
                                    band[ref.at(uint32_t(bx), uint32_t(by))] = 1;
                            }
                    }
                }
    size_t bandCount = 0;
    for (uint8_t b : band) bandCount += b;
    for (TraceQuality q :
         {TraceQuality::Low, TraceQuality::Medium, TraceQuality::High, TraceQuality::Reference}) {
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h, q), g));
        const float limit = float(scene::tracePreset(q).maxSteps);
        size_t atLimit = 0, atLimitBand = 0;
        double maxSteps = 0;
        for (size_t i = 0; i < g.size(); ++i) {
            maxSteps = std::max(maxSteps, double(g.aux[i].y));
            if (g.aux[i].y >= limit) {
                ++atLimit;
                atLimitBand += band[i];
            }
        }
        const double shareBand = bandCount ? double(atLimitBand) / double(bandCount) : 0.0;
        const double shareAll = double(atLimit) / double(g.size());
        summary("07 step limit", backend(),
                "%-9s limit %4.0f: %zu px ran out (%.3f %% of all, <= 0.2 %%), %zu in the silhouette band of "
                "%zu px "
                "(%.3f %%, <= 1 %%), max steps %.0f",
                scene::toString(q), double(limit), atLimit, 100 * shareAll, atLimitBand, bandCount,
                100 * shareBand, maxSteps);
        EXPECT_TRUE(checkSanity(g, 0.1f, 100.0f).ok());
        EXPECT_LE(shareBand, 0.01) << scene::toString(q);
        EXPECT_LE(shareAll, 0.002) << scene::toString(q);
    }
}

// ---- 10. the same scene at 1e-3, 1 and 1e4 units ---------------------------------------------------------

// A sphere, a rotated box and a ground plane, camera and near/far planes all scaled by k (entity
// positions and scales times k), a directional light and ambient (scale-free shading). Criteria:
// (a) the mean relative depth error against the exact cast (pixels hit in both, cos >= 0.3) at k is
// within a factor 2 of the unscaled one; (b) the lit image at k matches the unscaled one under the
// parity rule (tests/support/golden.h: per channel <= 5/255 for all but 0.1 % of pixels, none over
// 64/255) - images are scale-free after normalising by k.
TEST_P(Stability, Case10_SceneAt1em3And1e4Units) {
    constexpr uint32_t w = 128, h = 96;
    ImageRGBA8 unscaled;
    double meanUnscaled = 0;
    for (double k : {1.0, 1e-3, 1e4}) {
        const float kf = float(k);
        StabScene s(glm::vec3(0.0f, 0.6f, 0.0f) * kf, glm::vec3(0.0f, 0.0f, -3.0f) * kf, 0.1f * kf,
                    100.0f * kf);
        const ecs::Entity sphere =
            s.shape(ShapeNode::sphere(0.6), glm::vec3(-0.7f, 0.1f, -3.0f) * kf, {1, 0, 0, 0}, glm::vec3(kf));
        const glm::quat boxRot = glm::quat(glm::radians(glm::vec3(0, 35, 0)));
        const ecs::Entity box = s.shape(ShapeNode::box({0.4, 0.5, 0.4}), glm::vec3(0.8f, 0.0f, -3.3f) * kf,
                                        boxRot, glm::vec3(kf));
        const ecs::Entity ground = s.shape(ShapeNode::plane({0, 1, 0}, 0.0),
                                           glm::vec3(0.0f, -0.5f, 0.0f) * kf, {1, 0, 0, 0}, glm::vec3(kf));
        const ecs::Entity sun = s.world.create();
        s.world.add<ecs::Transform>(sun)->rotation = lookRotation({-0.3f, -1.0f, -0.5f});
        ecs::Light light;
        light.type = ecs::LightType::Directional;
        light.intensity = 2.0f;
        s.world.add<ecs::Light>(sun, light);
        ecs::updateTransforms(s.world);
        SceneRenderer r(dev());
        FrameDesc d = s.frame(w, h);
        d.settings.ambient = glm::vec3(0.1f);
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, d, g));
        ImageRGBA8 image;
        std::string error;
        ASSERT_TRUE(r.readPixels(image, error)) << error;
        const RefCamera cam(s.world, s.camera, w, h);
        auto pos = [&](ecs::Entity e) { return glm::dvec3(s.world.get<ecs::Transform>(e)->worldMatrix[3]); };
        const glm::dmat4 boxModel(s.world.get<ecs::Transform>(box)->worldMatrix);
        const glm::dmat4 boxInv = glm::inverse(boxModel);
        auto exact = [&](const glm::dvec3& o, const glm::dvec3& dir) {
            Hit best = raySphere(o, dir, pos(sphere), 0.6 * k, cam.nearPlane);
            best.id = int(sphere.index);
            const glm::dvec3 lo((boxInv * glm::dvec4(o, 1.0))), ld(glm::dmat3(boxInv) * dir);
            Hit hb = rayBox(lo, ld, glm::dvec3(0.0), glm::dvec3(0.4, 0.5, 0.4), cam.nearPlane);
            if (hb.s != kInf) hb.n = glm::normalize(glm::dmat3(boxModel) * hb.n);
            hb.id = int(box.index);
            if (hb.s < best.s) best = hb;
            Hit hp = rayPlane(o, dir, {0, 1, 0}, pos(ground).y, cam.nearPlane);
            hp.id = int(ground.index);
            if (hp.s < best.s) best = hp;
            return best;
        };
        double sum = 0;
        size_t n = 0;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                const glm::dvec3 dir = cam.dir(x, y);
                const Hit hh = exact(cam.eye, dir);
                if (hh.s > 0.9 * cam.farPlane || !g.hit(g.at(x, y))) continue;
                if (std::abs(glm::dot(hh.n, glm::normalize(dir))) < 0.3) continue;
                sum += relErr(g.depth[g.at(x, y)], hh.s);
                ++n;
            }
        const double mean = n ? sum / double(n) : 0.0;
        if (k == 1.0) {
            unscaled = image;
            meanUnscaled = mean;
            summary("10 scaled scenes", backend(), "k = 1: mean rel. depth error %.3e over %zu px", mean, n);
            EXPECT_GT(n, size_t(w) * h / 3);
            continue;
        }
        const ImageDiff diff = compareImages(image, unscaled);
        const double ratio = meanUnscaled > 0 ? mean / meanUnscaled : 0.0;
        summary("10 scaled scenes", backend(),
                "k = %g: mean rel. depth error %.3e over %zu px, ratio to k = 1 %.3f (in [0.5, 2]); image vs "
                "k = 1: %s "
                "(parity rule)",
                k, mean, n, ratio, diff.summary().c_str());
        EXPECT_TRUE(checkSanity(g, 0.1f * kf, 100.0f * kf).ok());
        EXPECT_GE(ratio, 0.5) << "k = " << k;
        EXPECT_LE(ratio, 2.0) << "k = " << k;
        EXPECT_TRUE(diff.pass) << "k = " << k << ": " << diff.summary();
    }
}

// ---- 12. unusable and non-uniform transforms
// -----------------------------------------------------------------

// A sphere that renders, and a box named 'broken' with a zero, negative or NaN scale, a NaN translation,
// or a parent with a NaN translation. Criterion (scene_renderer.cpp gatherSdfs, FORMATS.md "sdf"):
// over two frames of one renderer the box is skipped with exactly one warning naming it, and the
// sphere's pixels are bit-identical (depth and ids) to a frame without the box. A non-uniform scale
// is not skipped but traced conservatively (documented): an ellipsoid (unit sphere scaled (2, 0.5, 1))
// against its exact cast: no interior hole and perpendicular error <= 4 * hitEpsilon footprints *
// (sigma_max / sigma_min = 4) - conservative distances stop up to that ratio early.
TEST_P(Stability, Case12_BadTransformsAreSkippedNonUniformIsConservative) {
    constexpr uint32_t w = 128, h = 96;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    struct Bad {
        const char* what;
        glm::vec3 position, scale;
        bool nanParent;
    };
    const Bad cases[] = {{"zero scale", {1, 0, -4}, glm::vec3(0.0f), false},
                         {"one zero axis", {1, 0, -4}, {1, 0, 1}, false},
                         {"negative scale", {1, 0, -4}, glm::vec3(-1.0f), false},
                         {"mirroring axis", {1, 0, -4}, {1, -1, 1}, false},
                         {"NaN scale", {1, 0, -4}, glm::vec3(nan), false},
                         {"NaN translation", {nan, 0, -4}, glm::vec3(1.0f), false},
                         {"NaN parent translation", {1, 0, -4}, glm::vec3(1.0f), true}};
    GBuffer clean;
    {
        StabScene s;
        s.shape(ShapeNode::sphere(0.8), {-1, 0, -4});
        SceneRenderer r(dev());
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), clean));
    }
    for (const Bad& bad : cases) {
        WarningCapture capture;
        StabScene s;
        const ecs::Entity good = s.shape(ShapeNode::sphere(0.8), {-1, 0, -4});
        const ecs::Entity broken =
            s.shape(ShapeNode::box({0.5, 0.5, 0.5}), bad.position, {1, 0, 0, 0}, bad.scale, "broken");
        if (bad.nanParent) {
            const ecs::Entity parent = s.placed({nan, 0, 0}, {1, 0, 0, 0}, glm::vec3(1), "parent");
            ASSERT_TRUE(ecs::setParent(s.world, broken, parent));
        }
        SceneRenderer r(dev());
        size_t identical = 0, brokenPx = 0;
        for (int frame = 0; frame < 2; ++frame) {
            GBuffer g;
            ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), g));
            EXPECT_TRUE(checkSanity(g, 0.1f, 100.0f).ok());
            EXPECT_EQ(r.lastFrameStats().sdfObjects, 1u) << bad.what;
            identical = 0;
            for (size_t i = 0; i < g.size(); ++i) {
                brokenPx += g.id(i) == int(broken.index);
                identical += std::memcmp(&g.depth[i], &clean.depth[i], 4) == 0 &&
                             (g.hit(i) ? g.id(i) == int(good.index) : g.id(i) == -1);
            }
        }
        const size_t warnings = capture.count("'broken'");
        summary("12 bad transforms", backend(),
                "%-22s: %zu warning(s) naming 'broken' (1), %zu of %zu px identical to the clean frame (all)",
                bad.what, warnings, identical, clean.size());
        EXPECT_EQ(warnings, 1u) << bad.what << ": one warning naming the entity over two frames";
        EXPECT_EQ(brokenPx, 0u) << bad.what;
        EXPECT_EQ(identical, clean.size()) << bad.what << ": the rest renders as without the broken object";
    }
    {
        StabScene s;
        const glm::dvec3 scale(2.0, 0.5, 1.0);
        const ecs::Entity e = s.shape(ShapeNode::sphere(1.0), {0.2f, -0.1f, -4.0f},
                                      glm::quat(glm::radians(glm::vec3(10, 25, 5))), glm::vec3(scale));
        ecs::updateTransforms(s.world);
        SceneRenderer r(dev());
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), g));
        const RefCamera cam(s.world, s.camera, w, h);
        const glm::dmat4 model(s.world.get<ecs::Transform>(e)->worldMatrix);
        const glm::dmat4 inv = glm::inverse(model);
        auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
            const glm::dvec3 lo(inv * glm::dvec4(o, 1.0)), ld(glm::dmat3(inv) * d);
            Hit hh = raySphere(lo, ld, glm::dvec3(0.0), 1.0, cam.nearPlane);
            if (hh.s != kInf) hh.n = glm::normalize(glm::transpose(glm::dmat3(inv)) * hh.n);
            hh.id = int(e.index);
            return hh;
        };
        const double bound = 4.0 * presetEps(TraceQuality::Medium) * 4.0;
        const DepthStats st = compareDepth(g, cam, exact, bound, 0.0, kInf);
        size_t interiorHoles = 0;
        for (uint32_t y = 1; y + 1 < h; ++y)
            for (uint32_t x = 1; x + 1 < w; ++x) {
                bool all = true;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx)
                        all = all && exact(cam.eye, cam.dir(x + dx, y + dy)).s != kInf;
                interiorHoles += all && !g.hit(g.at(x, y));
            }
        summary("12 non-uniform scale", backend(),
                "(2, 0.5, 1): %zu px hit in both, interior holes %zu (0), perp. error max %.3f fp (<= %.1f), "
                "%zu over, "
                "%zu behind (0), rel. depth error p99 %.2e",
                st.both, interiorHoles, st.maxPerpFootprints, bound, st.overBound, st.behind,
                quantile(st.rel, 0.99));
        EXPECT_EQ(interiorHoles, 0u);
        EXPECT_EQ(st.overBound, 0u);
        EXPECT_EQ(st.behind, 0u);
    }
}

// ---- 13. a grazing far root must not hide a nearer surface ----------------------------------------------

// A box C on a ground plane, and in front of it a thin bar (0.02 deep, 0.02 high) that one row of rays
// passes 0.0015 under while the ground is within the hit epsilon: the bar's object is the hit
// candidate, a near miss, and the ground's own search (it is within eps of the point) finds its root
// far on, past C. Two variants:
//   rod: the bar is an object of its own, in the order C, rod, ground (C comes before the ground in
//        every candidate list, so it had been passed over against eps only);
//   bar: the bar is part of C (a union), no rod: C is the candidate, its own search ends at the
//        bar's near miss, and C's box behind it was never searched again.
// The hit decision (sdf_march.glsl) took the ground's far root behind C in both; it now starts the
// scan over against the gap to a first root found by a later candidate, the candidate's own object
// included, and such searches go on past a near miss up to the best root. The ground enters the
// hit epsilon at a point t* swept over five offsets in front of the bar (the camera height
// follows), so that the march meets the bar as nearest while the ground is within eps. Criterion,
// acceleration none and culling: no traced point behind the exact first surface
// (stability_util.h compareDepth, float slack 1e-5 t), and every exact hit of C in the bar's row
// traced as C. Measured before the fix (Vulkan, at 3ddd5ed): rod, without acceleration all 16 C
// pixels of the row were the ground behind C at every offset, with culling 0 (its steps reach the
// rod elsewhere); bar, all 16 in both configurations. After: 0 in every variant, offset and
// configuration, both backends.
TEST_P(Stability, Case13_AGrazingFarRootDoesNotHideANearerSurface) {
    constexpr uint32_t w = 160, h = 90, row = 48;
    const double zBar = 9.8, barHalfDepth = 0.02, gap = 0.0015;
    const glm::dvec3 cC(0.0, 0.15, -10.4), cE(1.0, 0.15, 0.2);
    const double offsets[] = {0.005, 0.01, 0.02, 0.03, 0.04};
    for (bool ownObject : {true, false}) {
        for (double offset : offsets) {
            // The row's slope (drop per unit depth) and footprint from a level camera.
            StabScene probe({0, 1, 0}, {0, 1, -1});
            ecs::updateTransforms(probe.world);
            const RefCamera pc(probe.world, probe.camera, w, h);
            const glm::dvec3 d0 = pc.dir(w / 2, row);
            const double slope = -d0.y, fp = pc.footprint(), len = glm::length(d0);
            // At depth t* = front face - offset the ground is eps below the ray: y(t*) = eps(t*).
            const double tStar = zBar - barHalfDepth - offset;
            const double yStar = presetEps(TraceQuality::Medium) * fp * tStar * len;
            const double eye = yStar + slope * tStar;
            const double yBar = eye - slope * zBar;  // the ray's height under the bar's centre
            StabScene s({0, float(eye), 0}, {0, float(eye), -1}, 0.1f, 100.0f);
            const glm::dvec3 bC(0.0, yBar + gap + 0.01, -zBar), bE(ownObject ? 3.0 : 1.0, 0.01, barHalfDepth);
            const ecs::Entity c =
                ownObject ? s.shape(ShapeNode::box(cE), glm::vec3(cC))
                          : s.shape(ShapeNode::csg(sdf::CsgOp::Union, {ShapeNode::box(bE).placed(bC),
                                                                       ShapeNode::box(cE).placed(cC)}),
                                    {0, 0, 0});
            const ecs::Entity bar = ownObject ? s.shape(ShapeNode::box(bE), glm::vec3(bC)) : c;
            // The floor a box (bounded, like the benchmark room's): its top face is its box's entry.
            const glm::dvec3 fC(0.0, -0.1, -6.0), fE(8.0, 0.1, 12.0);
            const ecs::Entity ground = s.shape(ShapeNode::box(fE), glm::vec3(fC));
            ecs::updateTransforms(s.world);
            const RefCamera cam(s.world, s.camera, w, h);
            auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
                Hit hc = rayBox(o, d, cC, cE, cam.nearPlane), hb = rayBox(o, d, bC, bE, cam.nearPlane),
                    hg = rayPlane(o, d, {0, 1, 0}, 0.0, cam.nearPlane);
                hc.id = int(c.index);
                hb.id = int(bar.index);
                hg.id = int(ground.index);
                Hit best = hc;
                if (hb.s < best.s) best = hb;
                if (hg.s < best.s) best = hg;
                return best;
            };
            const glm::dvec3 dRow = cam.dir(w / 2, row);
            ASSERT_EQ(exact(cam.eye, dRow).id, int(c.index)) << "the row's ray passes under the bar";
            ASSERT_LT(rayBox(cam.eye, dRow, cC, cE, cam.nearPlane).s,
                      rayPlane(cam.eye, dRow, {0, 1, 0}, 0.0, 0.0).s);
            SceneRenderer r(dev());
            for (bool culling : {false, true}) {
                FrameDesc fd = s.frame(w, h);
                fd.settings.acceleration.culling = culling;
                GBuffer g;
                ASSERT_TRUE(renderAndRead(s, r, fd, g));
                const DepthStats st = compareDepth(g, cam, exact, 4.0 * presetEps(TraceQuality::Medium), 0.0,
                                                   0.9 * cam.farPlane);
                size_t rowC = 0, rowCWrong = 0;
                for (uint32_t x = 0; x < w; ++x) {
                    const glm::dvec3 dx = cam.dir(x, row);
                    if (rayBox(cam.eye, dx, cC, cE, cam.nearPlane).s != exact(cam.eye, dx).s) continue;
                    ++rowC;
                    rowCWrong += g.id(g.at(x, row)) != int(c.index);
                }
                summary("13 grazing far root", backend(),
                        "%s, t* %.3f before it, %s: %zu behind (0), row %u: %zu exact C px, %zu not C (0)",
                        ownObject ? "rod" : "bar", offset, culling ? "culling" : "none   ", st.behind, row,
                        rowC, rowCWrong);
                EXPECT_GT(rowC, 5u);
                EXPECT_EQ(st.behind, 0u) << "traced points behind the exact first surface";
                EXPECT_EQ(rowCWrong, 0u) << "row " << row << ": C hidden by a farther root";
            }
        }
    }
}

// ---- 14. a crowd of boxes and spheres: culled steps against exact casts ----------------------------------

// 48 objects (axis-aligned boxes and spheres, sizes 0.1-0.6, seeded positions in a 6 x 2 x 10 volume
// in front of the camera, half of them standing on the floor, many overlapping on screen and in
// depth) on a floor that is a box (bounded, like the benchmark room's: its top face is its box's
// entry), at 160 x 90, without acceleration and with culling (whose march steps to the entry of the
// nearest listed box ahead, sdf_march.glsl). Criteria against exact ray casts, both backends: no
// traced point behind the exact first surface (stability_util.h compareDepth, float slack 1e-5 t),
// no interior hole and no interior pixel on another object (a pixel whose ray and its 8
// neighbours' rays first hit the same object, exactly; 6498 of them), and culling's ids equal to
// the unaccelerated frame's there. Measured: 0 everywhere on both backends. A mutation that lets a
// step reach the box ahead past the evaluated objects' distance gives 287 points behind, 9 holes
// and 63 pixels on another object; the near-miss bound lost in the first version of the step
// (docs/ACCURACY.md) needed baked fields' near misses beside a floor box and does not show here
// (BoxTrace.Objects200Effects caught it).
TEST_P(Stability, Case14_ACrowdOfBoxesAndSpheresAgainstExactCasts) {
    constexpr uint32_t w = 160, h = 90;
    StabScene s({0, 1.5f, 2.0f}, {0, 0.5f, -6.0f}, 0.1f, 100.0f);
    struct Obj {
        bool sphere;
        glm::dvec3 c, e;  // centre; half extents (x: radius for a sphere)
        ecs::Entity entity;
    };
    std::vector<Obj> objs;
    uint32_t state = 12345u;
    auto rnd = [&state] {  // xorshift32 in [0, 1)
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        return double(state) / 4294967296.0;
    };
    for (int i = 0; i < 48; ++i) {
        Obj o;
        o.sphere = i % 2 == 0;
        o.c = {-3.0 + 6.0 * rnd(), 0.1 + 2.0 * rnd(), -2.0 - 10.0 * rnd()};
        o.e = o.sphere ? glm::dvec3(0.1 + 0.5 * rnd())
                       : glm::dvec3(0.1 + 0.5 * rnd(), 0.1 + 0.5 * rnd(), 0.1 + 0.5 * rnd());
        if (i % 4 < 2) o.c.y = o.e.y;  // half of them stand on the floor
        o.entity = o.sphere ? s.shape(ShapeNode::sphere(o.e.x), glm::vec3(o.c))
                            : s.shape(ShapeNode::box(o.e), glm::vec3(o.c));
        objs.push_back(o);
    }
    // The floor a box (bounded, like the benchmark room's): its top face is its box's entry.
    const glm::dvec3 fC(0.0, -0.1, -6.0), fE(8.0, 0.1, 12.0);
    const ecs::Entity ground = s.shape(ShapeNode::box(fE), glm::vec3(fC));
    ecs::updateTransforms(s.world);
    const RefCamera cam(s.world, s.camera, w, h);
    auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
        Hit best = rayBox(o, d, fC, fE, cam.nearPlane);
        best.id = int(ground.index);
        for (const Obj& b : objs) {
            Hit hb =
                b.sphere ? raySphere(o, d, b.c, b.e.x, cam.nearPlane) : rayBox(o, d, b.c, b.e, cam.nearPlane);
            hb.id = int(b.entity.index);
            if (hb.s < best.s) best = hb;
        }
        return best;
    };
    std::vector<int> exactId(size_t(w) * h);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const Hit hh = exact(cam.eye, cam.dir(x, y));
            exactId[size_t(y) * w + x] = hh.s < 0.9 * cam.farPlane ? hh.id : -1;
        }
    auto interior = [&](uint32_t x, uint32_t y) {
        const int id = exactId[size_t(y) * w + x];
        if (id < 0 || x == 0 || y == 0 || x + 1 == w || y + 1 == h) return false;
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx)
                if (exactId[size_t(y + dy) * w + (x + dx)] != id) return false;
        return true;
    };
    SceneRenderer r(dev());
    std::vector<int> noneIds;
    for (bool culling : {false, true}) {
        FrameDesc fd = s.frame(w, h);
        fd.settings.acceleration.culling = culling;
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, fd, g));
        const DepthStats st =
            compareDepth(g, cam, exact, 4.0 * presetEps(TraceQuality::Medium), 0.0, 0.9 * cam.farPlane);
        size_t inner = 0, holes = 0, wrong = 0, differs = 0;
        std::vector<int> ids(size_t(w) * h);
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                const size_t i = g.at(x, y);
                ids[i] = g.hit(i) ? g.id(i) : -1;
                if (!interior(x, y)) continue;
                ++inner;
                holes += !g.hit(i);
                wrong += g.hit(i) && g.id(i) != exactId[i];
                if (culling) differs += ids[i] != noneIds[i];
            }
        if (!culling) noneIds = ids;
        summary("14 crowd of 48 objects", backend(),
                "%s: %zu interior px, holes %zu (0), other object %zu (0), %zu behind (0)%s",
                culling ? "culling" : "none   ", inner, holes, wrong, st.behind,
                culling ? (", ids differ from none on " + std::to_string(differs) + " (0)").c_str() : "");
        EXPECT_GT(inner, size_t(w) * h / 3);
        EXPECT_EQ(holes, 0u);
        EXPECT_EQ(wrong, 0u);
        EXPECT_EQ(st.behind, 0u) << "traced points behind the exact first surface";
        if (culling) {
            EXPECT_EQ(differs, 0u);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, Stability, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test::stability
