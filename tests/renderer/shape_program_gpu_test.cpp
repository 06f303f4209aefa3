// The GPU shape-program evaluator (renderer/shaders/shape_program.glsl) against the double-precision
// CPU reference sdf::evaluateShapeProgram, on both backends under validation (issue 10, acceptance
// "conservative distance by the GPU shader code").
//
// 17 programs cover every shape, rotated / translated / scaled nodes, hard and smooth union,
// subtraction and intersection, bounded repetition (the PopRepeat bound of the copies not
// evaluated), the deepest stacks the limits allow (16 distances, 8 frames) and a shape ~1000 units
// from its program's origin. 100 000 points in all (fixed seed), in three groups per program:
// uniform in the program's bounds (inside and around the solid), projected onto the surface and
// jittered (near), and log-uniform out to 100 bound sizes from the centre (far outside). One compute
// dispatch per variant evaluates them all: the default evaluator (conservative margin) and the
// SHAPE_EVAL_NO_MARGIN variant (raw float).
//
// PrimitiveShortcutEqualsTheInterpreter: the trace's shortcut for programs of one shape
// (evalShapePrimitive, the SHAPE_PRIMITIVES variants of sdf_trace.comp) returns bit for bit what
// the interpreter returns, for each of the 8 shapes at 2 000 points (inside, near and far), and
// sdfShapePrimitivesOnly picks exactly the frames it may serve (every pass that evaluates objects).
//
// Criteria, with tol(cpu) = 1e-5 * max(1, |cpu|):
//  - conservative (the rule): |gpu| <= |cpu| + tol(cpu) at every point. Outside the solid
//    this is gpu <= cpu + tol, "never exceeds the exact distance by more than 1e-5 relative"
//    (for the exact programs cpu is the exact distance; for the bounded ones |cpu| is at most the
//    exact distance, so the GPU value is then below the exact one as well). Inside, the magnitude
//    is what a tracer steps by, so the rule is on |d| there too (a signed rule would forbid the
//    CPU reference's own inside bounds);
//  - agreement: |raw - cpu| <= 8 float ulps of M = max(1, |p|inf, the program's bounds) =
//    2^-20 * M (float rounds at the magnitude of the coordinates, not of the distance), and
//    |gpu - cpu| <= 2^-16 * M with the conservative margin (2^-19 of the magnitudes met, a few M
//    here, plus the rounding);
//  - coverage: the groups hold 40%, 40% and 20% of the points (at least 39%, 39% and 19% after
//    rounding per program), at least 15% of all points are inside, and at least 20% lie within
//    1e-2 of the surface.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/gtc/quaternion.hpp>

#include <shaders/shape_eval.h>

#include "engine/sdf/shape_program.h"
#include "renderer/core/gpu_cache.h"
#include "renderer/core/shader_params.h"
#include "renderer/features/sdf_scene.h"
#include "support/test_device.h"

namespace {

namespace sdf = penumbra::sdf;
namespace eval = penumbra::shaders::shape_eval;
using penumbra::render::GpuCache;
using penumbra::render::ShaderParams;
using sdf::CsgOp;
using sdf::ShapeNode;

static_assert(sizeof(eval::ShapeInstruction) == sizeof(sdf::ShapeInstruction),
              "the GLSL record and sdf::ShapeInstruction must have one layout");
static_assert(offsetof(eval::ShapeInstruction, a) == offsetof(sdf::ShapeInstruction, a));
static_assert(offsetof(eval::ShapeInstruction, c) == offsetof(sdf::ShapeInstruction, c));

constexpr size_t kTotalPoints = 100000;

glm::dquat rot(double angle, glm::dvec3 axis) { return glm::angleAxis(angle, glm::normalize(axis)); }

// The deepest program the limits allow: 15 right-nested unions (16 distances), 8 nested frames.
ShapeNode deepChain(int level) {
    if (level == 0) return ShapeNode::torus(0.3, 0.08).placed({0.1, 0, 0}, rot(0.4, {1, 0, 1}), 0.9);
    ShapeNode first =
        ShapeNode::sphere(0.05 + 0.01 * level).placed({0.2 * std::cos(level), 0.15 * level, 0.1});
    if (level == 13) first = ShapeNode::box({0.1, 0.2, 0.05});  // the boxes and cones stay unplaced:
    if (level == 9) first = ShapeNode::cone(0.1, 0.0, 0.1);     // their frame is the parent's
    ShapeNode node = ShapeNode::csg(CsgOp::Union, {first, deepChain(level - 1)}, level % 4 == 1 ? 0.05 : 0.0);
    if (level <= 7) node.placed({0.05, -0.03 * level, 0.02}, rot(0.3 * level, {1, 2, 3}), 1.1);
    return node;
}

struct Case {
    std::string name;
    ShapeNode root;
};

std::vector<Case> cases() {
    const glm::dquat r1 = rot(0.7, {1, 2, 3});
    const glm::dquat r2 = rot(2.1, {-1, 0.5, 0.25});
    std::vector<Case> c;
    c.push_back({"sphere", ShapeNode::sphere(0.8).placed({0.3, -0.2, 0.5}, r1, 1.3)});
    c.push_back({"box", ShapeNode::box({0.5, 0.8, 0.3}).placed({-1, 0.5, 2}, r2, 0.7)});
    c.push_back({"roundedBox", ShapeNode::roundedBox({0.6, 0.4, 0.5}, 0.15).placed({0, 0, 0}, r1, 1.7)});
    c.push_back({"capsule", ShapeNode::capsule(0.3, 0.6).placed({2, 1, -1}, r2)});
    c.push_back({"cylinder", ShapeNode::cylinder(0.4, 0.7).placed({0.5, 0, 0}, r1, 0.6)});
    c.push_back({"torus", ShapeNode::torus(0.7, 0.2).placed({0, 3, 0}, r2, 2.0)});
    c.push_back({"cone", ShapeNode::cone(0.6, 0.2, 0.5).placed({0, 0, 1}, r1, 1.2)});
    c.push_back({"cone apex", ShapeNode::cone(0.5, 0.0, 0.6).placed({-0.5, 0, 0}, r2)});
    c.push_back({"plane in box", ShapeNode::csg(CsgOp::Intersect,
                                                {ShapeNode::box({1, 1, 1}), ShapeNode::plane({1, 2, 3}, 0.3)})
                                     .placed({0.2, 0.1, 0}, r1, 1.5)});
    c.push_back(
        {"subtract", ShapeNode::csg(CsgOp::Subtract, {ShapeNode::box({1, 1, 1}), ShapeNode::sphere(1.2)})
                         .placed({0, 0, 0}, r2, 0.8)});
    c.push_back({"intersect", ShapeNode::csg(CsgOp::Intersect, {ShapeNode::cylinder(0.5, 1.0).placed({}, r1),
                                                                ShapeNode::sphere(0.8)})});
    c.push_back(
        {"smooth ops",
         ShapeNode::csg(
             CsgOp::Subtract,
             {ShapeNode::csg(CsgOp::Intersect,
                             {ShapeNode::csg(CsgOp::Union,
                                             {ShapeNode::sphere(0.6),
                                              ShapeNode::box({0.4, 0.4, 0.4}).placed({0.7, 0, 0}, r1)},
                                             0.3),
                              ShapeNode::sphere(1.0).placed({0.3, 0, 0})},
                             0.25),
              ShapeNode::cylinder(0.2, 1.5)},
             0.2)
             .placed({0.1, 0.2, 0.3}, r2, 1.5)});
    c.push_back({"repeat", ShapeNode::repeat(ShapeNode::capsule(0.15, 0.2).placed({0, 0, 0}, r1), {1, 0, 1.2},
                                             {5, 1, 3})
                               .placed({0, 0, 0}, r2)});
    c.push_back(
        {"repeat of smooth csg",
         ShapeNode::repeat(
             ShapeNode::csg(CsgOp::Union,
                            {ShapeNode::torus(0.25, 0.08), ShapeNode::sphere(0.15).placed({0, 0.2, 0})}, 0.1),
             {0.8, 0.9, 0.9}, {3, 4, 2})
             .placed({1, -1, 0.5}, r1, 0.75)});
    c.push_back({"repeat of a scaled box",
                 ShapeNode::repeat(ShapeNode::box({0.2, 0.1, 0.15}).placed({0, 0.05, 0}, {1, 0, 0, 0}, 0.8),
                                   {0.5, 0, 0.6}, {4, 1, 2})
                     .placed({-0.5, 0.25, 1}, r2, 1.3)});
    // Far from the program's origin: float rounds at |p| ~ 1000 (~6e-5 per ulp), more than the
    // 1e-5 the rule allows near the surface; the conservative margin covers it.
    c.push_back({"far from the origin",
                 ShapeNode::csg(CsgOp::Subtract, {ShapeNode::box({0.6, 0.5, 0.4}),
                                                  ShapeNode::sphere(0.6).placed({0.3, 0.3, 0})})
                     .placed({900, -400, 300}, r1, 1.5)});
    c.push_back({"deep stacks", deepChain(15)});
    return c;
}

struct Program {
    std::string name;
    sdf::ShapeProgram program;
    uint32_t first = 0;  // header record index in the shared buffer
    glm::dvec3 lo{0.0}, hi{0.0};
};

enum Group { Box, Near, Far };

struct Sample {
    glm::vec3 p{0.0f};
    uint32_t program = 0;  // index into programs
    Group group = Box;
    double cpu = 0.0;
};

struct Data {
    std::vector<Program> programs;
    std::vector<sdf::ShapeInstruction> records;
    std::vector<Sample> samples;
    std::string error;
};

glm::dvec3 gradient(const sdf::ShapeProgram& p, const glm::dvec3& x, double h) {
    const glm::dvec3 ex(h, 0, 0), ey(0, h, 0), ez(0, 0, h);
    return glm::dvec3(sdf::evaluateShapeProgram(p, x + ex) - sdf::evaluateShapeProgram(p, x - ex),
                      sdf::evaluateShapeProgram(p, x + ey) - sdf::evaluateShapeProgram(p, x - ey),
                      sdf::evaluateShapeProgram(p, x + ez) - sdf::evaluateShapeProgram(p, x - ez)) /
           (2.0 * h);
}

// Compiles root and appends it to out (records, programs); false with out.error set on failure.
bool addProgram(Data& out, const std::string& name, const ShapeNode& root) {
    Program p;
    p.name = name;
    if (!sdf::compileShapeProgram(root, p.program, out.error)) {
        out.error = name + ": " + out.error;
        return false;
    }
    p.first = uint32_t(out.records.size());
    p.lo = glm::dvec3(glm::vec3(p.program.records[0].a));
    p.hi = glm::dvec3(glm::vec3(p.program.records[0].b));
    out.records.insert(out.records.end(), p.program.records.begin(), p.program.records.end());
    out.programs.push_back(std::move(p));
    return true;
}

// Built once for both backends (deterministic: fixed seed, no dependence on the backend).
const Data& data() {
    static const Data d = [] {
        Data out;
        for (const Case& c : cases())
            if (!addProgram(out, c.name, c.root)) return out;
        std::mt19937_64 rng(20261201);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::normal_distribution<double> n(0.0, 1.0);
        const size_t perProgram = kTotalPoints / out.programs.size();
        for (uint32_t pi = 0; pi < out.programs.size(); ++pi) {
            const Program& prog = out.programs[pi];
            const glm::dvec3 centre = 0.5 * (prog.lo + prog.hi), size = prog.hi - prog.lo;
            const double extent = std::max({size.x, size.y, size.z});
            const size_t count = pi + 1 == out.programs.size() ? kTotalPoints - perProgram * pi : perProgram;
            for (size_t i = 0; i < count; ++i) {
                Sample s;
                s.program = pi;
                glm::dvec3 x;
                const double g = double(i) / double(count);
                auto inBox = [&] { return centre + (glm::dvec3(u(rng), u(rng), u(rng)) - 0.5) * size * 1.1; };
                if (g < 0.4) {
                    s.group = Box;
                    x = inBox();
                } else if (g < 0.8) {
                    // Newton steps onto the zero set, then a jitter of up to 1e-3 extent.
                    s.group = Near;
                    x = inBox();
                    for (int k = 0; k < 6; ++k) {
                        const double d = sdf::evaluateShapeProgram(prog.program, x);
                        const glm::dvec3 grad = gradient(prog.program, x, 1e-6 * extent);
                        const double g2 = glm::dot(grad, grad);
                        if (!(g2 > 1e-12)) break;
                        x -= grad * (d / g2);
                    }
                    x += glm::normalize(glm::dvec3(n(rng), n(rng), n(rng))) * (u(rng) * 1e-3 * extent);
                } else {
                    s.group = Far;
                    const glm::dvec3 dir = glm::normalize(glm::dvec3(n(rng), n(rng), n(rng)));
                    x = centre + dir * extent * std::pow(100.0, u(rng));
                }
                s.p = glm::vec3(x);
                s.cpu = sdf::evaluateShapeProgram(prog.program, glm::dvec3(s.p));
                out.samples.push_back(s);
            }
        }
        return out;
    }();
    return d;
}

class ShapeProgramGpu : public penumbra::test::GpuTest {
protected:
    // Evaluates every sample with the variant; empty after a failed assertion.
    std::vector<float> evaluate(const Data& d, eval::Variant variant) {
        const rhi::ShaderDesc& cs = eval::compute(variant);
        std::vector<eval::ShapeInstruction> records(d.records.size());
        for (size_t i = 0; i < records.size(); ++i) {
            const sdf::ShapeInstruction& r = d.records[i];
            records[i].head = glm::uvec4(r.op, r.i[0], r.i[1], r.i[2]);
            records[i].a = r.a;
            records[i].b = r.b;
            records[i].c = r.c;
        }
        std::vector<eval::EvalPoint> points(d.samples.size());
        for (size_t i = 0; i < points.size(); ++i) {
            points[i].p = d.samples[i].p;
            points[i].program = d.programs[d.samples[i].program].first;
        }
        rhi::BufferDesc bd;
        bd.usage = rhi::BufferUsage::Storage;
        bd.size = records.size() * sizeof(records[0]);
        bd.debugName = "shape records";
        const rhi::BufferHandle recordBuffer = dev().createBuffer(bd, records.data());
        bd.size = points.size() * sizeof(points[0]);
        bd.debugName = "points";
        const rhi::BufferHandle pointBuffer = dev().createBuffer(bd, points.data());
        bd.size = points.size() * sizeof(float);
        bd.usage = rhi::BufferUsage::Storage | rhi::BufferUsage::CopySrc;
        bd.debugName = "distances";
        const rhi::BufferHandle outBuffer = dev().createBuffer(bd);
        std::vector<float> out;
        GpuCache cache(dev());
        const rhi::PipelineHandle pipeline = cache.computePipeline(cs);
        if (pipeline.isValid() && recordBuffer.isValid() && pointBuffer.isValid() && outBuffer.isValid()) {
            rhi::CommandList& cmd = dev().beginCommandList("shape eval");
            cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("ShapeRecords", recordBuffer)
                .set("EvalPoints", pointBuffer)
                .set("EvalDistances", outBuffer);
            const bool bound = params.bind(cmd, cache, pipeline);
            EXPECT_TRUE(bound) << params.error();
            eval::PushConstants push;
            push.count = glm::uvec4(uint32_t(points.size()), 0, 0, 0);
            cmd.pushConstants(&push, sizeof(push));
            if (bound) penumbra::render::dispatchOver(cmd, cs, uint32_t(points.size()), 1);
            cmd.barrier(rhi::Barrier::buf(outBuffer, rhi::Access::ShaderWrite, rhi::Access::HostRead));
            dev().waitForSubmission(dev().submit(cmd));
            out.resize(points.size());
            if (!bound || !dev().readBuffer(outBuffer, 0, out.size() * sizeof(float), out.data()))
                out.clear();
        } else {
            ADD_FAILURE() << "could not create the pipeline or the buffers";
        }
        dev().waitIdle();
        dev().destroy(recordBuffer);
        dev().destroy(pointBuffer);
        dev().destroy(outBuffer);
        return out;
    }
};

double magnitude(const Program& prog, const glm::vec3& p) {
    double m = std::max({1.0, std::abs(double(p.x)), std::abs(double(p.y)), std::abs(double(p.z))});
    for (int k = 0; k < 3; ++k) m = std::max({m, std::abs(prog.lo[k]), std::abs(prog.hi[k])});
    return m;
}

TEST_P(ShapeProgramGpu, ConservativeAndAgreesWithTheCpuReference) {
    const auto t0 = std::chrono::steady_clock::now();
    const Data& d = data();
    ASSERT_TRUE(d.error.empty()) << d.error;
    ASSERT_EQ(d.samples.size(), kTotalPoints);
    // The programs reach every opcode and the limits' stack depths.
    bool seen[36] = {};
    uint32_t maxDistances = 0, maxFrames = 0;
    for (const Program& p : d.programs) {
        for (const sdf::ShapeInstruction& r : p.program.records) seen[std::min(r.op, 35u)] = true;
        maxDistances = std::max(maxDistances, p.program.maxDistanceStack);
        maxFrames = std::max(maxFrames, p.program.maxFrameStack);
    }
    for (uint32_t op : {1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 16u, 17u, 18u, 19u, 20u, 21u, 32u, 33u, 34u, 35u})
        EXPECT_TRUE(seen[op]) << "opcode " << op << " is not exercised";
    const sdf::ShapeProgramLimits limits;
    EXPECT_EQ(maxDistances, limits.maxDistanceStack);
    EXPECT_EQ(maxFrames, limits.maxFrameStack);

    // Coverage (criterion in the header).
    size_t groups[3] = {}, inside = 0, nearSurface = 0;
    for (const Sample& s : d.samples) {
        ++groups[s.group];
        inside += s.cpu < 0.0;
        nearSurface += std::abs(s.cpu) < 1e-2;
    }
    // The groups are 40%, 40% and 20% of each program's points (rounded per program).
    EXPECT_GE(groups[Box], kTotalPoints * 39 / 100);
    EXPECT_GE(groups[Near], kTotalPoints * 39 / 100);
    EXPECT_GE(groups[Far], kTotalPoints * 19 / 100);
    EXPECT_GE(inside, kTotalPoints * 15 / 100);
    EXPECT_GE(nearSurface, kTotalPoints / 5);
    const auto t1 = std::chrono::steady_clock::now();

    const std::vector<float> gpu = evaluate(d, eval::Variant::Default);
    const std::vector<float> raw = evaluate(d, eval::Variant::ShapeEvalNoMargin);
    ASSERT_EQ(gpu.size(), d.samples.size());
    ASSERT_EQ(raw.size(), d.samples.size());
    const auto t2 = std::chrono::steady_clock::now();

    double worstRawRel = 0.0, worstRawM = 0.0, worstGpuM = 0.0, worstExcess = -1.0, worstRawExcess = -1.0;
    size_t rawViolations = 0, failures = 0;
    for (size_t i = 0; i < d.samples.size(); ++i) {
        const Sample& s = d.samples[i];
        const Program& prog = d.programs[s.program];
        const double cpu = s.cpu, g = gpu[i], r = raw[i];
        const double tol = 1e-5 * std::max(1.0, std::abs(cpu));
        const double m = magnitude(prog, s.p);
        // Conservative: |gpu| <= |cpu| + 1e-5 * max(1, |cpu|) (the rule).
        worstExcess = std::max(worstExcess, (std::abs(g) - std::abs(cpu)) / tol);
        const bool conservative = std::isfinite(g) && std::abs(g) <= std::abs(cpu) + tol;
        // Agreement of the raw value: |raw - cpu| <= 2^-20 * M (8 float ulps of M).
        const bool rawAgrees = std::isfinite(r) && std::abs(r - cpu) <= std::ldexp(m, -20);
        // Agreement of the conservative value: |gpu - cpu| <= 2^-16 * M.
        const bool gpuAgrees = std::abs(g - cpu) <= std::ldexp(m, -16);
        worstRawM = std::max(worstRawM, std::abs(r - cpu) / m);
        worstGpuM = std::max(worstGpuM, std::abs(g - cpu) / m);
        worstRawRel = std::max(worstRawRel, std::abs(r - cpu) / std::max(1.0, std::abs(cpu)));
        worstRawExcess = std::max(worstRawExcess, (std::abs(r) - std::abs(cpu)) / tol);
        rawViolations += std::abs(r) > std::abs(cpu) + tol;
        if ((!conservative || !rawAgrees || !gpuAgrees) && ++failures <= 10) {
            ADD_FAILURE() << prog.name << " point " << i << " (" << s.p.x << ", " << s.p.y << ", " << s.p.z
                          << ") group " << s.group << ": cpu " << cpu << " gpu " << g << " raw " << r << " M "
                          << m << (conservative ? "" : " [overestimates]")
                          << (rawAgrees ? "" : " [raw disagrees]") << (gpuAgrees ? "" : " [gpu disagrees]");
        }
    }
    EXPECT_EQ(failures, 0u);
    const auto t3 = std::chrono::steady_clock::now();
    auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
    std::printf(
        "[ shape eval ] %zu points (%zu in box, %zu near, %zu far; %zu inside, %zu within 1e-2): "
        "raw float |gpu-cpu| max %.3g * M (%.3g relative to max(1,|cpu|)), max (|raw|-|cpu|)/tol %.3g "
        "(%zu over tol without the margin); with the margin |gpu-cpu| max %.3g * M, max (|gpu|-|cpu|)/tol "
        "%.3g; points %.0f ms, GPU %.0f ms, checks %.0f ms\n",
        d.samples.size(), groups[Box], groups[Near], groups[Far], inside, nearSurface, worstRawM, worstRawRel,
        worstRawExcess, rawViolations, worstGpuM, worstExcess, ms(t0, t1), ms(t1, t2), ms(t2, t3));
}

// Programs of one shape instruction, one per shape, and points around each (fixed seed).
const Data& primitiveData() {
    static const Data d = [] {
        Data out;
        const std::vector<Case> shapes = {{"sphere", ShapeNode::sphere(0.8)},
                                          {"box", ShapeNode::box({0.5, 0.8, 0.3})},
                                          {"roundedBox", ShapeNode::roundedBox({0.6, 0.4, 0.5}, 0.15)},
                                          {"capsule", ShapeNode::capsule(0.3, 0.6)},
                                          {"cylinder", ShapeNode::cylinder(0.4, 0.7)},
                                          {"torus", ShapeNode::torus(0.7, 0.2)},
                                          {"cone", ShapeNode::cone(0.6, 0.2, 0.5)},
                                          {"plane", ShapeNode::plane({1, 2, 3}, 0.3)}};
        std::mt19937_64 rng(20261202);
        std::uniform_real_distribution<double> u(-1.5, 1.5);
        std::uniform_real_distribution<double> far(1.0, 3.0);
        for (const Case& c : shapes) {
            const uint32_t index = uint32_t(out.programs.size());
            if (!addProgram(out, c.name, c.root)) return out;
            for (int i = 0; i < 2000; ++i) {
                Sample s;
                s.program = index;
                const glm::dvec3 x(u(rng), u(rng), u(rng));
                // A quarter of the points out to 1000 units (float rounds at larger magnitudes).
                s.p = glm::vec3(i % 4 == 3 ? x * std::pow(10.0, far(rng)) : x);
                s.cpu = sdf::evaluateShapeProgram(out.programs[index].program, glm::dvec3(s.p));
                out.samples.push_back(s);
            }
        }
        return out;
    }();
    return d;
}

TEST_P(ShapeProgramGpu, PrimitiveShortcutEqualsTheInterpreter) {
    const Data& d = primitiveData();
    ASSERT_TRUE(d.error.empty()) << d.error;
    ASSERT_EQ(d.programs.size(), 8u);
    for (const Program& p : d.programs) {
        // Header + one shape: the programs the shortcut serves.
        ASSERT_EQ(p.program.records.size(), 2u) << p.name;
        ASSERT_EQ(p.program.records[0].i[1], 1u) << p.name;
    }
    const std::vector<float> interpreter = evaluate(d, eval::Variant::Default);
    const std::vector<float> shortcut = evaluate(d, eval::Variant::ShapePrimitive);
    ASSERT_EQ(interpreter.size(), d.samples.size());
    ASSERT_EQ(shortcut.size(), d.samples.size());
    size_t differ = 0, inside = 0;
    for (size_t i = 0; i < d.samples.size(); ++i) {
        inside += interpreter[i] < 0.0f;
        // Bit for bit: the same arithmetic, so the trace's picture cannot depend on the variant.
        if (std::memcmp(&interpreter[i], &shortcut[i], sizeof(float)) != 0 && ++differ <= 10)
            ADD_FAILURE() << d.programs[d.samples[i].program].name << " point " << i << ": interpreter "
                          << interpreter[i] << ", shortcut " << shortcut[i];
    }
    EXPECT_EQ(differ, 0u);
    EXPECT_GE(inside, d.samples.size() / 20);  // the points reach inside the solids, too

    // sdfShapePrimitivesOnly: one-shape programs only, among all objects.
    using penumbra::render::GpuSdfObject;
    using penumbra::render::SdfKind;
    penumbra::render::SdfSceneData scene;
    scene.records = d.records;
    auto object = [](SdfKind kind, uint32_t first) {
        GpuSdfObject o{};
        o.info = glm::uvec4(uint32_t(kind), first, 0, 0);
        return o;
    };
    for (const Program& p : d.programs) scene.objects.push_back(object(SdfKind::Shapes, p.first));
    scene.objects.push_back(object(SdfKind::Field, 0));  // fields do not matter
    scene.tracedCount = uint32_t(scene.objects.size());
    EXPECT_TRUE(penumbra::render::sdfShapePrimitivesOnly(scene));
    // A program of more instructions (a placed shape) among them: the interpreter.
    sdf::ShapeProgram placed;
    std::string error;
    ASSERT_TRUE(
        sdf::compileShapeProgram(ShapeNode::sphere(0.5).placed({1, 0, 0}, {1, 0, 0, 0}, 1.0), placed, error))
        << error;
    ASSERT_GT(placed.records[0].i[1], 1u);
    penumbra::render::SdfSceneData mixed = scene;
    const uint32_t first = uint32_t(mixed.records.size());
    mixed.records.insert(mixed.records.end(), placed.records.begin(), placed.records.end());
    mixed.objects.insert(mixed.objects.begin(), object(SdfKind::Shapes, first));
    mixed.tracedCount = uint32_t(mixed.objects.size());
    EXPECT_FALSE(penumbra::render::sdfShapePrimitivesOnly(mixed));
    // ... also as an untraced object (the shadows and AO see every object).
    std::rotate(mixed.objects.begin(), mixed.objects.begin() + 1, mixed.objects.end());
    mixed.tracedCount = uint32_t(mixed.objects.size()) - 1;
    EXPECT_FALSE(penumbra::render::sdfShapePrimitivesOnly(mixed));
    // No shape object at all: nothing to save.
    penumbra::render::SdfSceneData fieldsOnly;
    fieldsOnly.objects.push_back(object(SdfKind::Field, 0));
    fieldsOnly.tracedCount = 1;
    EXPECT_FALSE(penumbra::render::sdfShapePrimitivesOnly(fieldsOnly));
}

INSTANTIATE_TEST_SUITE_P(Backends, ShapeProgramGpu, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
