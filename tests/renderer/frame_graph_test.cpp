// Frame graph unit tests on the null device: culling, barrier placement (checked against the
// recorded command stream), transient allocation, aliasing and pooling, timings, Graphviz and
// error handling. Deterministic; no GPU needed.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "renderer/frame_graph/frame_graph.h"
#include "rhi/device.h"
#include "rhi/null/null_device.h"

namespace {

using penumbra::fg::BufferRef;
using penumbra::fg::FrameGraph;
using penumbra::fg::PassBuilder;
using penumbra::fg::PassContext;
using penumbra::fg::PassKind;
using penumbra::fg::TextureRef;
using rhi::Access;
using Kind = rhi::null::RecordedCommand::Kind;
using Commands = std::vector<rhi::null::RecordedCommand>;

struct Empty {};
struct TexData {
    TextureRef tex;
};
struct TwoTex {
    TextureRef in;
    TextureRef out;
};
struct BufData {
    BufferRef buf;
};

rhi::TextureDesc colorDesc(uint32_t w = 64, uint32_t h = 64, rhi::Format f = rhi::Format::RGBA8_UNORM) {
    rhi::TextureDesc d;
    d.format = f;
    d.width = w;
    d.height = h;
    return d;
}

bool sameBarrier(const rhi::Barrier& a, const rhi::Barrier& b) {
    return a.texture == b.texture && a.buffer == b.buffer && a.before == b.before && a.after == b.after;
}

// Index of the first command at or after `from` satisfying `pred`, or -1.
template <typename Pred>
int find(const Commands& cmds, Pred pred, int from = 0) {
    for (int i = std::max(from, 0); i < int(cmds.size()); ++i)
        if (pred(cmds[i])) return i;
    return -1;
}

int findKind(const Commands& cmds, Kind kind, int from = 0) {
    return find(
        cmds, [&](const rhi::null::RecordedCommand& c) { return c.kind == kind; }, from);
}

int findGroup(const Commands& cmds, const std::string& name) {
    return find(cmds, [&](const rhi::null::RecordedCommand& c) {
        return c.kind == Kind::PushDebugGroup && c.label == name;
    });
}

// Indices of barrier commands containing `b`.
std::vector<int> barrierCommandsWith(const Commands& cmds, const rhi::Barrier& b) {
    std::vector<int> out;
    for (int i = 0; i < int(cmds.size()); ++i) {
        if (cmds[i].kind != Kind::Barrier) continue;
        for (const rhi::Barrier& x : cmds[i].barriers)
            if (sameBarrier(x, b)) out.push_back(i);
    }
    return out;
}

class FrameGraphTest : public testing::Test {
protected:
    void SetUp() override {
        rhi::DeviceDesc desc;
        desc.backend = rhi::Backend::Null;
        desc.validation = true;
        desc.log = [this](rhi::LogSeverity s, std::string_view msg) {
            if (s == rhi::LogSeverity::Error) m_deviceErrors.emplace_back(msg);
        };
        m_device = rhi::createDevice(desc);
        ASSERT_NE(m_device, nullptr);
        m_graph = std::make_unique<FrameGraph>(*m_device, [this](rhi::LogSeverity s, std::string_view msg) {
            if (s == rhi::LogSeverity::Error) m_graphErrors.emplace_back(msg);
        });
        // Binding-free pipelines so the validation layer accepts the passes' dispatches and draws.
        rhi::ShaderDesc cs;
        cs.stage = rhi::ShaderStage::Compute;
        cs.debugName = "fg_test.comp";
        rhi::ShaderDesc vs;
        vs.stage = rhi::ShaderStage::Vertex;
        vs.debugName = "fg_test.vert";
        rhi::ShaderDesc fs;
        fs.stage = rhi::ShaderStage::Fragment;
        fs.debugName = "fg_test.frag";
        rhi::ComputePipelineDesc cp;
        cp.shader = dev().createShader(cs);
        cp.debugName = "fg_test compute";
        s_compute = dev().createComputePipeline(cp);
        rhi::GraphicsPipelineDesc gp;
        gp.vertexShader = dev().createShader(vs);
        gp.fragmentShader = dev().createShader(fs);
        gp.colorFormats = {rhi::Format::RGBA8_UNORM};
        gp.debugName = "fg_test raster";
        s_raster = dev().createGraphicsPipeline(gp);
        ASSERT_TRUE(s_compute.isValid() && s_raster.isValid());
    }

    void TearDown() override {
        m_graph.reset();
        if (m_device) m_device->waitIdle();
        for (const std::string& e : m_deviceErrors) ADD_FAILURE() << "device error: " << e;
    }

    rhi::Device& dev() { return *m_device; }
    FrameGraph& graph() { return *m_graph; }

    // A texture for importing, moved into `state` by a submitted barrier so imports tell the truth.
    rhi::TextureHandle makeTexture(const std::string& name, Access state = Access::None) {
        rhi::TextureDesc d = colorDesc();
        d.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::Storage | rhi::TextureUsage::ColorTarget |
                  rhi::TextureUsage::CopySrc | rhi::TextureUsage::CopyDst;
        d.debugName = name;
        rhi::TextureHandle handle = dev().createTexture(d);
        if (state != Access::None) {
            rhi::CommandList& cmd = dev().beginCommandList("setup");
            cmd.barrier(rhi::Barrier::tex(handle, Access::None, state));
            dev().submit(cmd);
        }
        return handle;
    }

    rhi::BufferHandle makeBuffer(const std::string& name, uint64_t size = 256) {
        rhi::BufferDesc d;
        d.size = size;
        d.usage = rhi::BufferUsage::Storage | rhi::BufferUsage::Uniform | rhi::BufferUsage::Indirect |
                  rhi::BufferUsage::CopySrc | rhi::BufferUsage::CopyDst;
        d.debugName = name;
        return dev().createBuffer(d);
    }

    // Records the frame into a new command list, submits it and returns what the device recorded.
    Commands run() {
        rhi::null::clearRecordedCommands(dev());
        rhi::CommandList& cmd = dev().beginCommandList("frame");
        graph().execute(cmd);
        dev().submit(cmd);
        return rhi::null::recordedCommands(dev());
    }

    // A raster pass that samples `in` and renders into `out` (a fullscreen triangle).
    void addShadePass(const std::string& name, TextureRef in, TextureRef out) {
        graph().addPass<TwoTex>(
            name, PassKind::Raster,
            [&](PassBuilder& b, TwoTex& d) {
                d.in = b.read(in, Access::ShaderSampled);
                d.out = b.write(out, Access::ColorTarget);
            },
            [](const TwoTex& d, PassContext& ctx) {
                rhi::RenderPassDesc rp;
                rhi::ColorAttachment a;
                a.texture = ctx.texture(d.out);
                rp.colorAttachments.push_back(a);
                rp.debugName = ctx.name();
                ctx.cmd.beginRenderPass(rp);
                ctx.cmd.bindPipeline(s_raster);
                ctx.cmd.draw(3);
                ctx.cmd.endRenderPass();
            });
    }

    // A compute pass that writes a new transient (ShaderWrite) and returns it.
    TextureRef addProducer(const std::string& name, const std::string& texName,
                           rhi::TextureDesc desc = colorDesc()) {
        return graph()
            .addPass<TexData>(
                name, PassKind::Compute,
                [&](PassBuilder& b, TexData& d) {
                    d.tex = b.write(b.createTexture(texName, desc), Access::ShaderWrite);
                },
                [](const TexData& d, PassContext& ctx) {
                    EXPECT_TRUE(ctx.texture(d.tex).isValid());
                    dispatch(ctx, 8, 8);
                })
            .tex;
    }

    std::unique_ptr<rhi::Device> m_device;
    std::unique_ptr<FrameGraph> m_graph;
    std::vector<std::string> m_deviceErrors;
    std::vector<std::string> m_graphErrors;

    static void dispatch(PassContext& ctx, uint32_t x, uint32_t y = 1) {
        ctx.cmd.bindPipeline(s_compute);
        ctx.cmd.dispatch(x, y);
    }

    // The pipelines bound by the test passes (set up per test; passes are plain lambdas).
    static inline rhi::PipelineHandle s_compute;
    static inline rhi::PipelineHandle s_raster;
};

// ---------------------------------------------------------------------------------------------
// Culling
// ---------------------------------------------------------------------------------------------
TEST_F(FrameGraphTest, CullsPassWhoseOutputIsUnused) {
    TextureRef target = graph().importTexture("target", makeTexture("target"), Access::None, Access::CopySrc);
    TextureRef field = addProducer("field", "field");
    TextureRef unused = addProducer("unused", "unusedTex");
    addShadePass("shade", field, target);
    (void)unused;
    ASSERT_TRUE(graph().compile());

    const auto& info = graph().compiled();
    EXPECT_EQ(info.culledPasses, std::vector<std::string>{"unused"});
    ASSERT_EQ(info.passes.size(), 2u);
    EXPECT_EQ(info.passes[0].name, "field");
    EXPECT_EQ(info.passes[1].name, "shade");
    EXPECT_EQ(info.transientCount, 1u);
    EXPECT_EQ(info.texturesCreated, 1u);  // the culled pass's transient is never allocated
    EXPECT_FALSE(graph().physicalTexture(unused).isValid());

    Commands cmds = run();
    EXPECT_GE(findGroup(cmds, "field"), 0);
    EXPECT_GE(findGroup(cmds, "shade"), 0);
    EXPECT_EQ(findGroup(cmds, "unused"), -1);
    EXPECT_EQ(std::count_if(cmds.begin(), cmds.end(), [](const auto& c) { return c.kind == Kind::Dispatch; }),
              1);
    EXPECT_TRUE(m_graphErrors.empty());
}

TEST_F(FrameGraphTest, CullsAChainOfUnusedPasses) {
    TextureRef target = graph().importTexture("target", makeTexture("target"), Access::None, Access::CopySrc);
    TextureRef a = addProducer("a", "A");
    TextureRef b = graph()
                       .addPass<TwoTex>(
                           "b", PassKind::Compute,
                           [&](PassBuilder& pb, TwoTex& d) {
                               d.in = pb.read(a, Access::ShaderSampled);
                               d.out = pb.write(pb.createTexture("B", colorDesc()), Access::ShaderWrite);
                           },
                           [](const TwoTex&, PassContext& ctx) { dispatch(ctx, 1); })
                       .out;
    graph().addPass<TwoTex>(
        "c", PassKind::Compute,
        [&](PassBuilder& pb, TwoTex& d) {
            d.in = pb.read(b, Access::ShaderSampled);
            d.out = pb.write(pb.createTexture("C", colorDesc()), Access::ShaderWrite);
        },
        [](const TwoTex&, PassContext& ctx) { dispatch(ctx, 1); });
    // A pass that only reads the import is not an output producer either.
    graph().addPass<TexData>(
        "peek", PassKind::Compute,
        [&](PassBuilder& pb, TexData& d) { d.tex = pb.read(target, Access::ShaderSampled); },
        [](const TexData&, PassContext& ctx) { dispatch(ctx, 1); });
    ASSERT_TRUE(graph().compile());

    const auto& info = graph().compiled();
    EXPECT_EQ(info.culledPasses, (std::vector<std::string>{"a", "b", "c", "peek"}));
    EXPECT_TRUE(info.passes.empty());
    EXPECT_EQ(info.physicalResourceCount, 0u);
    EXPECT_EQ(info.texturesCreated, 0u);

    Commands cmds = run();
    EXPECT_EQ(findKind(cmds, Kind::Dispatch), -1);
    EXPECT_EQ(findKind(cmds, Kind::PushDebugGroup), -1);
    EXPECT_TRUE(graph().collectTimings().empty());
}

TEST_F(FrameGraphTest, SideEffectPassIsNotCulledAndKeepsItsInputs) {
    TextureRef field = addProducer("field", "field");
    bool ran = false;
    graph().addPass<TexData>(
        "readback", PassKind::Transfer,
        [&](PassBuilder& b, TexData& d) {
            d.tex = b.read(field, Access::CopySrc);
            b.sideEffect();
        },
        [&](const TexData& d, PassContext& ctx) {
            ran = true;
            EXPECT_TRUE(ctx.texture(d.tex).isValid());
        });
    graph().addPass<Empty>(
        "counter", PassKind::Compute, [](PassBuilder& b, Empty&) { b.sideEffect(); },
        [](const Empty&, PassContext& ctx) { dispatch(ctx, 1); });
    ASSERT_TRUE(graph().compile());
    EXPECT_TRUE(graph().compiled().culledPasses.empty());
    EXPECT_EQ(graph().compiled().passes.size(), 3u);
    run();
    EXPECT_TRUE(ran);
}

TEST_F(FrameGraphTest, ImportedOutputKeepsItsProducersAndMarkOutputKeepsTransients) {
    rhi::BufferHandle counters = makeBuffer("counters");
    BufferRef imported = graph().importBuffer("counters", counters, Access::ShaderWrite);
    graph().addPass<BufData>(
        "count", PassKind::Compute,
        [&](PassBuilder& b, BufData& d) { d.buf = b.write(imported, Access::ShaderWrite); },
        [](const BufData& d, PassContext& ctx) {
            EXPECT_TRUE(ctx.buffer(d.buf).isValid());
            dispatch(ctx, 1);
        });
    TextureRef debug = addProducer("debugView", "debug");
    TextureRef dropped = addProducer("dropped", "dropped");
    graph().markOutput(debug, Access::CopySrc);
    ASSERT_TRUE(graph().compile());
    EXPECT_EQ(graph().compiled().culledPasses, std::vector<std::string>{"dropped"});
    EXPECT_TRUE(graph().physicalTexture(debug).isValid());
    EXPECT_FALSE(graph().physicalTexture(dropped).isValid());
    EXPECT_EQ(graph().physicalBuffer(imported), counters);
    // The output transient is moved to the requested state at the end of the frame.
    EXPECT_EQ(graph().finalState(debug), Access::CopySrc);
    const auto& fin = graph().compiled().finalBarriers;
    ASSERT_EQ(fin.size(), 1u);
    EXPECT_TRUE(sameBarrier(
        fin[0], rhi::Barrier::tex(graph().physicalTexture(debug), Access::ShaderWrite, Access::CopySrc)));
    run();
    dev().destroy(counters);
}

// ---------------------------------------------------------------------------------------------
// Barriers
// ---------------------------------------------------------------------------------------------
TEST_F(FrameGraphTest, ComputeWriteThenRasterReadGetsOneBarrierBetweenDispatchAndDraw) {
    rhi::TextureHandle targetTex = makeTexture("target");
    TextureRef target = graph().importTexture("target", targetTex, Access::None, Access::CopySrc);
    TextureRef field = addProducer("simulate", "field");
    addShadePass("shade", field, target);
    ASSERT_TRUE(graph().compile());
    rhi::TextureHandle fieldTex = graph().physicalTexture(field);
    ASSERT_TRUE(fieldTex.isValid());

    const auto* shade = graph().compiled().findPass("shade");
    ASSERT_NE(shade, nullptr);
    const rhi::Barrier expected = rhi::Barrier::tex(fieldTex, Access::ShaderWrite, Access::ShaderSampled);
    ASSERT_EQ(shade->barriers.size(), 2u);  // the field (RAW) and the target's first use
    EXPECT_TRUE(sameBarrier(shade->barriers[0], expected));
    EXPECT_TRUE(
        sameBarrier(shade->barriers[1], rhi::Barrier::tex(targetTex, Access::None, Access::ColorTarget)));
    const auto* simulate = graph().compiled().findPass("simulate");
    ASSERT_EQ(simulate->barriers.size(), 1u);
    EXPECT_TRUE(
        sameBarrier(simulate->barriers[0], rhi::Barrier::tex(fieldTex, Access::None, Access::ShaderWrite)));

    Commands cmds = run();
    std::vector<int> at = barrierCommandsWith(cmds, expected);
    ASSERT_EQ(at.size(), 1u) << "ShaderWrite -> ShaderSampled must be emitted exactly once";
    int dispatch = findKind(cmds, Kind::Dispatch);
    int begin = findKind(cmds, Kind::BeginRenderPass);
    int draw = findKind(cmds, Kind::Draw);
    ASSERT_GE(dispatch, 0);
    EXPECT_LT(dispatch, at[0]);
    EXPECT_LT(at[0], begin);
    EXPECT_LT(begin, draw);
    // One batch per pass: inside the shade pass's debug group, and no other barrier command
    // before its draw.
    int group = findGroup(cmds, "shade");
    EXPECT_LT(group, at[0]);
    int nextBarrier = findKind(cmds, Kind::Barrier, at[0] + 1);
    EXPECT_TRUE(nextBarrier == -1 || nextBarrier > draw);
    // Final transition of the import after the last pass.
    std::vector<int> fin =
        barrierCommandsWith(cmds, rhi::Barrier::tex(targetTex, Access::ColorTarget, Access::CopySrc));
    ASSERT_EQ(fin.size(), 1u);
    EXPECT_GT(fin[0], draw);
    EXPECT_EQ(graph().finalState(target), Access::CopySrc);
}

TEST_F(FrameGraphTest, NoBarrierBetweenTwoReadersInTheSameState) {
    TextureRef out1 =
        graph().importTexture("out1", makeTexture("out1", Access::ColorTarget), Access::ColorTarget);
    TextureRef out2 =
        graph().importTexture("out2", makeTexture("out2", Access::ColorTarget), Access::ColorTarget);
    TextureRef field = addProducer("produce", "field");
    addShadePass("readerA", field, out1);
    addShadePass("readerB", field, out2);
    ASSERT_TRUE(graph().compile());
    rhi::TextureHandle fieldTex = graph().physicalTexture(field);

    const auto* a = graph().compiled().findPass("readerA");
    const auto* b = graph().compiled().findPass("readerB");
    ASSERT_TRUE(a && b);
    ASSERT_EQ(a->barriers.size(), 2u);
    EXPECT_TRUE(
        sameBarrier(a->barriers[0], rhi::Barrier::tex(fieldTex, Access::ShaderWrite, Access::ShaderSampled)));
    // The import's ColorTarget -> ColorTarget is a write-after-write hazard across frames.
    EXPECT_EQ(a->barriers[1].before, Access::ColorTarget);
    EXPECT_EQ(b->barriers.size(), 1u);
    for (const rhi::Barrier& x : b->barriers) EXPECT_NE(x.texture, fieldTex);
    // Imports already in their final state need no final transition.
    EXPECT_TRUE(graph().compiled().finalBarriers.empty());

    Commands cmds = run();
    int groupB = findGroup(cmds, "readerB");
    ASSERT_GE(groupB, 0);
    for (int i = groupB; i < int(cmds.size()); ++i) {
        if (cmds[i].kind != Kind::Barrier) continue;
        for (const rhi::Barrier& x : cmds[i].barriers) EXPECT_NE(x.texture, fieldTex);
    }
}

TEST_F(FrameGraphTest, BufferReadAfterWriteAndWriteAfterWriteBarriers) {
    rhi::BufferHandle handle = makeBuffer("particles");
    BufferRef buf = graph().importBuffer("particles", handle, Access::None, Access::ShaderRead);
    auto writer = [&](const std::string& name, Access access, PassKind kind = PassKind::Compute) {
        graph().addPass<BufData>(
            name, kind, [&, access](PassBuilder& b, BufData& d) { d.buf = b.write(buf, access); },
            [](const BufData&, PassContext& ctx) { dispatch(ctx, 1); });
    };
    auto reader = [&](const std::string& name, Access access) {
        graph().addPass<BufData>(
            name, PassKind::Compute,
            [&, access](PassBuilder& b, BufData& d) {
                d.buf = b.read(buf, access);
                b.sideEffect();
            },
            [](const BufData&, PassContext& ctx) { dispatch(ctx, 1); });
    };
    writer("emit", Access::ShaderWrite);
    writer("simulate", Access::ShaderWrite);               // WAW
    reader("drawArgs", Access::ShaderRead);                // RAW
    reader("again", Access::ShaderRead);                   // same read state: none
    reader("uniforms", Access::UniformRead);               // another read state: one barrier
    writer("clear", Access::CopyDst, PassKind::Transfer);  // WAR
    ASSERT_TRUE(graph().compile());

    auto barriersOf = [&](const std::string& name) { return graph().compiled().findPass(name)->barriers; };
    ASSERT_EQ(barriersOf("emit").size(), 1u);
    EXPECT_TRUE(
        sameBarrier(barriersOf("emit")[0], rhi::Barrier::buf(handle, Access::None, Access::ShaderWrite)));
    ASSERT_EQ(barriersOf("simulate").size(), 1u);
    EXPECT_TRUE(sameBarrier(barriersOf("simulate")[0],
                            rhi::Barrier::buf(handle, Access::ShaderWrite, Access::ShaderWrite)));
    ASSERT_EQ(barriersOf("drawArgs").size(), 1u);
    EXPECT_TRUE(sameBarrier(barriersOf("drawArgs")[0],
                            rhi::Barrier::buf(handle, Access::ShaderWrite, Access::ShaderRead)));
    EXPECT_TRUE(barriersOf("again").empty());
    ASSERT_EQ(barriersOf("uniforms").size(), 1u);
    EXPECT_TRUE(sameBarrier(barriersOf("uniforms")[0],
                            rhi::Barrier::buf(handle, Access::ShaderRead, Access::UniformRead)));
    ASSERT_EQ(barriersOf("clear").size(), 1u);
    EXPECT_TRUE(
        sameBarrier(barriersOf("clear")[0], rhi::Barrier::buf(handle, Access::UniformRead, Access::CopyDst)));
    ASSERT_EQ(graph().compiled().finalBarriers.size(), 1u);
    EXPECT_TRUE(sameBarrier(graph().compiled().finalBarriers[0],
                            rhi::Barrier::buf(handle, Access::CopyDst, Access::ShaderRead)));
    EXPECT_EQ(graph().finalState(buf), Access::ShaderRead);

    // In the stream: the WAW barrier lies between the two writers' dispatches.
    Commands cmds = run();
    int first = findKind(cmds, Kind::Dispatch);
    int second = findKind(cmds, Kind::Dispatch, first + 1);
    std::vector<int> waw =
        barrierCommandsWith(cmds, rhi::Barrier::buf(handle, Access::ShaderWrite, Access::ShaderWrite));
    ASSERT_EQ(waw.size(), 1u);
    EXPECT_LT(first, waw[0]);
    EXPECT_LT(waw[0], second);
    dev().destroy(handle);
}

TEST_F(FrameGraphTest, ImportedResourcesEndInTheirFinalState) {
    rhi::TextureHandle backbuffer = makeTexture("backbuffer");
    rhi::TextureHandle history = makeTexture("history", Access::ShaderSampled);
    TextureRef bb = graph().importTexture("backbuffer", backbuffer, Access::None, Access::Present);
    TextureRef hist = graph().importTexture("history", history, Access::ShaderSampled, Access::ShaderRead);
    TextureRef field = addProducer("field", "field");
    addShadePass("compose", field, bb);
    ASSERT_TRUE(graph().compile());
    const auto& fin = graph().compiled().finalBarriers;
    // Untouched imports are transitioned too.
    ASSERT_EQ(fin.size(), 2u);
    EXPECT_TRUE(sameBarrier(fin[0], rhi::Barrier::tex(backbuffer, Access::ColorTarget, Access::Present)));
    EXPECT_TRUE(sameBarrier(fin[1], rhi::Barrier::tex(history, Access::ShaderSampled, Access::ShaderRead)));
    EXPECT_EQ(graph().finalState(bb), Access::Present);
    EXPECT_EQ(graph().finalState(hist), Access::ShaderRead);

    Commands cmds = run();
    int lastPop = -1;
    for (int i = 0; i < int(cmds.size()); ++i)
        if (cmds[i].kind == Kind::PopDebugGroup) lastPop = i;
    ASSERT_GE(lastPop, 0);
    ASSERT_EQ(cmds.back().kind, Kind::Barrier);
    EXPECT_EQ(cmds.back().barriers.size(), 2u);
    EXPECT_GT(int(cmds.size()) - 1, lastPop);
}

TEST_F(FrameGraphTest, ReadModifyWriteInOnePassUsesTheCombinedState) {
    TextureRef target =
        graph().importTexture("target", makeTexture("target", Access::ShaderSampled), Access::ShaderSampled);
    TextureRef field = addProducer("init", "field");
    graph().addPass<TexData>(
        "relax", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            d.tex = b.read(field, Access::ShaderRead);
            b.write(field, Access::ShaderWrite);
        },
        [](const TexData&, PassContext& ctx) { dispatch(ctx, 1); });
    graph().addPass<TwoTex>(
        "blit", PassKind::Transfer,
        [&](PassBuilder& b, TwoTex& d) {
            d.in = b.read(field, Access::CopySrc);
            d.out = b.write(target, Access::CopyDst);
        },
        [](const TwoTex&, PassContext&) {});
    ASSERT_TRUE(graph().compile());
    rhi::TextureHandle t = graph().physicalTexture(field);
    const auto* relax = graph().compiled().findPass("relax");
    ASSERT_EQ(relax->barriers.size(), 1u);
    EXPECT_TRUE(sameBarrier(relax->barriers[0], rhi::Barrier::tex(t, Access::ShaderWrite,
                                                                  Access::ShaderRead | Access::ShaderWrite)));
    EXPECT_TRUE(graph().compiled().culledPasses.empty());
    EXPECT_TRUE(m_graphErrors.empty());
}

// ---------------------------------------------------------------------------------------------
// Transients: usage, aliasing, pooling, memory
// ---------------------------------------------------------------------------------------------
TEST_F(FrameGraphTest, TransientUsageIsTheUnionOfItsAccesses) {
    TextureRef target =
        graph().importTexture("target", makeTexture("target", Access::ColorTarget), Access::ColorTarget);
    TextureRef gbuffer = graph()
                             .addPass<TexData>(
                                 "gbuffer", PassKind::Raster,
                                 [&](PassBuilder& b, TexData& d) {
                                     rhi::TextureDesc desc = colorDesc(32, 16, rhi::Format::RGBA16_FLOAT);
                                     desc.usage = rhi::TextureUsage::Storage;  // ignored: usage is derived
                                     d.tex = b.write(b.createTexture("gbuffer", desc), Access::ColorTarget);
                                 },
                                 [](const TexData&, PassContext&) {})
                             .tex;
    addShadePass("light", gbuffer, target);
    rhi::BufferDesc bd;
    bd.size = 1024;
    BufferRef args = graph()
                         .addPass<BufData>(
                             "cull", PassKind::Compute,
                             [&](PassBuilder& b, BufData& d) {
                                 d.buf = b.write(b.createBuffer("args", bd), Access::ShaderWrite);
                             },
                             [](const BufData&, PassContext&) {})
                         .buf;
    graph().addPass<BufData>(
        "drawIndirect", PassKind::Raster,
        [&](PassBuilder& b, BufData& d) {
            d.buf = b.read(args, Access::IndirectRead);
            b.sideEffect();
        },
        [](const BufData&, PassContext&) {});
    ASSERT_TRUE(graph().compile());
    const rhi::TextureDesc* td = dev().describe(graph().physicalTexture(gbuffer));
    ASSERT_NE(td, nullptr);
    EXPECT_EQ(td->usage,
              rhi::TextureUsage::Sampled | rhi::TextureUsage::ColorTarget | rhi::TextureUsage::CopySrc);
    EXPECT_EQ(td->format, rhi::Format::RGBA16_FLOAT);
    EXPECT_EQ(td->width, 32u);
    const rhi::BufferDesc* b = dev().describe(graph().physicalBuffer(args));
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(b->usage, rhi::BufferUsage::Storage | rhi::BufferUsage::Indirect | rhi::BufferUsage::CopySrc);
    EXPECT_EQ(b->size, 1024u);
    // Memory estimate: 32 * 16 * 8 bytes + 1024 bytes.
    EXPECT_EQ(graph().compiled().transientMemoryBytes, 32u * 16u * 8u + 1024u);
    EXPECT_EQ(graph().compiled().physicalTextureCount, 1u);
    EXPECT_EQ(graph().compiled().physicalBufferCount, 1u);
    EXPECT_EQ(graph().compiled().physicalResourceCount, 2u);
    run();
}

TEST_F(FrameGraphTest, NonOverlappingTransientsOfTheSameDescAlias) {
    TextureRef out1 =
        graph().importTexture("out1", makeTexture("out1", Access::ColorTarget), Access::ColorTarget);
    TextureRef out2 =
        graph().importTexture("out2", makeTexture("out2", Access::ColorTarget), Access::ColorTarget);
    TextureRef t1 = addProducer("p1", "t1");
    addShadePass("r1", t1, out1);
    TextureRef t2 = addProducer("p2", "t2");
    addShadePass("r2", t2, out2);
    // Different shape: never aliased with t1/t2.
    TextureRef small = addProducer("p3", "small", colorDesc(16, 16));
    addShadePass("r3", small, out2);
    ASSERT_TRUE(graph().compile());

    const auto& info = graph().compiled();
    EXPECT_EQ(info.transientCount, 3u);
    EXPECT_EQ(info.physicalTextureCount, 2u);
    EXPECT_EQ(info.texturesCreated, 2u);
    rhi::TextureHandle h1 = graph().physicalTexture(t1);
    EXPECT_EQ(h1, graph().physicalTexture(t2));
    EXPECT_NE(h1, graph().physicalTexture(small));
    EXPECT_EQ(info.transientMemoryBytes, 64u * 64u * 4u + 16u * 16u * 4u);
    // The second life starts in None again (contents discarded).
    const auto* p2 = info.findPass("p2");
    ASSERT_EQ(p2->barriers.size(), 1u);
    EXPECT_TRUE(sameBarrier(p2->barriers[0], rhi::Barrier::tex(h1, Access::None, Access::ShaderWrite)));
    std::string dot = graph().toGraphviz();
    EXPECT_NE(dot.find("aliased with t2"), std::string::npos) << dot;
    run();
}

TEST_F(FrameGraphTest, OverlappingTransientsDoNotAlias) {
    TextureRef out =
        graph().importTexture("out", makeTexture("out", Access::ColorTarget), Access::ColorTarget);
    TextureRef t1 = addProducer("p1", "t1");
    TextureRef t2 = addProducer("p2", "t2");
    graph().addPass<TwoTex>(
        "combine", PassKind::Raster,
        [&](PassBuilder& b, TwoTex& d) {
            d.in = b.read(t1, Access::ShaderSampled);
            b.read(t2, Access::ShaderSampled);
            d.out = b.write(out, Access::ColorTarget);
        },
        [](const TwoTex&, PassContext&) {});
    ASSERT_TRUE(graph().compile());
    EXPECT_EQ(graph().compiled().physicalTextureCount, 2u);
    EXPECT_NE(graph().physicalTexture(t1), graph().physicalTexture(t2));
    run();
}

// A persistent buffer (the SDF object array kept across frames) enters each frame in the state
// the previous compiled frame left it in, without its owner tracking it.
TEST_F(FrameGraphTest, PersistentBufferKeepsItsStateAcrossFrames) {
    rhi::BufferHandle handle = makeBuffer("objects");
    rhi::TextureHandle tex = makeTexture("tex");
    EXPECT_EQ(graph().persistentState(handle), Access::None);  // never imported
    for (int frame = 0; frame < 3; ++frame) {
        graph().reset();
        BufferRef buf = graph().importPersistent("objects", handle, Access::ShaderRead);
        ASSERT_TRUE(buf.isValid());
        graph().importPersistent("tex", tex, Access::ShaderSampled);  // same handle value space apart
        if (frame != 1)                                               // frame 1 only reads: nothing to upload
            graph().addPass<BufData>(
                "upload", PassKind::Transfer,
                [&](PassBuilder& b, BufData& d) { d.buf = b.write(buf, Access::CopyDst); },
                [](const BufData&, PassContext&) {});
        graph().addPass<BufData>(
            "consume", PassKind::Compute,
            [&](PassBuilder& b, BufData& d) {
                d.buf = b.read(buf, Access::ShaderRead);
                b.sideEffect();
            },
            [](const BufData&, PassContext& ctx) { dispatch(ctx, 1); });
        ASSERT_TRUE(graph().compile());
        const auto& consume = graph().compiled().findPass("consume")->barriers;
        if (frame == 0) {
            // First import: from None; the upload's CopyDst then the read.
            const auto& upload = graph().compiled().findPass("upload")->barriers;
            ASSERT_EQ(upload.size(), 1u);
            EXPECT_TRUE(sameBarrier(upload[0], rhi::Barrier::buf(handle, Access::None, Access::CopyDst)));
        } else if (frame == 1) {
            EXPECT_TRUE(consume.empty()) << "frame 1 enters in ShaderRead: no barrier";
        } else {
            const auto& upload = graph().compiled().findPass("upload")->barriers;
            ASSERT_EQ(upload.size(), 1u);
            EXPECT_TRUE(
                sameBarrier(upload[0], rhi::Barrier::buf(handle, Access::ShaderRead, Access::CopyDst)));
        }
        if (frame != 1) {
            ASSERT_EQ(consume.size(), 1u);
            EXPECT_TRUE(
                sameBarrier(consume[0], rhi::Barrier::buf(handle, Access::CopyDst, Access::ShaderRead)));
        }
        run();
        EXPECT_EQ(graph().persistentState(handle), Access::ShaderRead) << "frame " << frame;
    }
    graph().forgetPersistent(handle);
    EXPECT_EQ(graph().persistentState(handle), Access::None);
    EXPECT_EQ(graph().persistentState(tex), Access::ShaderSampled);  // textures tracked apart
    dev().destroy(handle);
    dev().destroy(tex);
}

TEST_F(FrameGraphTest, TransientsAreReusedAcrossFrames) {
    rhi::TextureHandle targetTex = makeTexture("target", Access::ColorTarget);
    std::vector<rhi::TextureHandle> handles;
    size_t liveAfterFirst = 0;
    for (int frame = 0; frame < 3; ++frame) {
        graph().reset();
        TextureRef target = graph().importTexture("target", targetTex, Access::ColorTarget);
        TextureRef field = addProducer("field", "field");
        addShadePass("shade", field, target);
        rhi::BufferDesc bd;
        bd.size = 512;
        graph().addPass<BufData>(
            "scratch", PassKind::Compute,
            [&](PassBuilder& b, BufData& d) {
                d.buf = b.write(b.createBuffer("scratch", bd), Access::ShaderWrite);
                b.sideEffect();
            },
            [](const BufData&, PassContext&) {});
        ASSERT_TRUE(graph().compile());
        handles.push_back(graph().physicalTexture(field));
        const auto& info = graph().compiled();
        if (frame == 0) {
            EXPECT_EQ(info.texturesCreated, 1u);
            EXPECT_EQ(info.buffersCreated, 1u);
        } else {
            EXPECT_EQ(info.texturesCreated, 0u) << "frame " << frame;
            EXPECT_EQ(info.buffersCreated, 0u) << "frame " << frame;
        }
        run();
        graph().collectTimings();
        if (frame == 0)
            liveAfterFirst = rhi::null::liveObjectCount(dev());
        else
            EXPECT_EQ(rhi::null::liveObjectCount(dev()), liveAfterFirst) << "frame " << frame;
    }
    EXPECT_EQ(handles[0], handles[1]);
    EXPECT_EQ(handles[1], handles[2]);
    EXPECT_EQ(graph().pooledTextureCount(), 1u);
    EXPECT_EQ(graph().pooledBufferCount(), 1u);
}

TEST_F(FrameGraphTest, UnusedPoolEntriesAreReleasedAfterNFrames) {
    rhi::TextureHandle targetTex = makeTexture("target", Access::ColorTarget);
    auto frame = [&](bool withField) {
        graph().reset();
        TextureRef target = graph().importTexture("target", targetTex, Access::ColorTarget);
        if (withField) {
            TextureRef field = addProducer("field", "field");
            addShadePass("shade", field, target);
        }
        EXPECT_TRUE(graph().compile());
        run();
    };
    dev().waitIdle();
    const size_t baseline = rhi::null::liveObjectCount(dev());
    frame(true);
    EXPECT_EQ(graph().pooledTextureCount(), 1u);
    frame(false);  // unused 1 frame
    frame(false);  // unused 2 frames
    EXPECT_EQ(graph().pooledTextureCount(), 1u);
    EXPECT_EQ(graph().compiled().poolEntriesReleased, 0u);
    frame(false);  // unused 3 frames: released (default retain = 3)
    EXPECT_EQ(graph().pooledTextureCount(), 0u);
    EXPECT_EQ(graph().compiled().poolEntriesReleased, 1u);
    dev().waitIdle();
    // Only the ring of timestamp query pools (one per frame in flight) is left besides what
    // existed before.
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), baseline + penumbra::fg::kTimingFramesInFlight);

    // Configurable: with retain = 1 an entry goes at the first frame that does not use it.
    graph().setPoolRetainFrames(1);
    frame(true);
    EXPECT_EQ(graph().pooledTextureCount(), 1u);
    frame(false);
    EXPECT_EQ(graph().pooledTextureCount(), 0u);
}

// ---------------------------------------------------------------------------------------------
// Timings, Graphviz
// ---------------------------------------------------------------------------------------------
TEST_F(FrameGraphTest, TimingsForEveryExecutedPassAndNoneForCulled) {
    TextureRef target =
        graph().importTexture("target", makeTexture("target", Access::ColorTarget), Access::ColorTarget);
    TextureRef field = addProducer("field", "field");
    addProducer("culled", "nobody");
    addShadePass("shade", field, target);
    ASSERT_TRUE(graph().compile());
    Commands cmds = run();
    // Two timestamps per executed pass, after a reset of the pool.
    EXPECT_EQ(
        std::count_if(cmds.begin(), cmds.end(), [](const auto& c) { return c.kind == Kind::WriteTimestamp; }),
        4);
    EXPECT_GE(findKind(cmds, Kind::ResetQueries), 0);
    EXPECT_LT(findKind(cmds, Kind::ResetQueries), findKind(cmds, Kind::WriteTimestamp));

    auto timings = graph().collectTimings();
    ASSERT_EQ(timings.size(), 2u);
    EXPECT_EQ(timings[0].name, "field");
    EXPECT_EQ(timings[1].name, "shade");
    for (const auto& t : timings) {
        EXPECT_GE(t.cpuMs, 0.0);
        if (dev().info().limits.timestamps)
            EXPECT_GE(t.gpuMs, 0.0) << t.name;
        else
            EXPECT_TRUE(std::isnan(t.gpuMs));
    }
    // Cached: a second call returns the same values.
    auto again = graph().collectTimings();
    ASSERT_EQ(again.size(), 2u);
    EXPECT_EQ(again[1].cpuMs, timings[1].cpuMs);
}

TEST_F(FrameGraphTest, QueryPoolGrowsWithThePassCount) {
    rhi::TextureHandle targetTex = makeTexture("target", Access::ColorTarget);
    TextureRef target = graph().importTexture("target", targetTex, Access::ColorTarget);
    addShadePass("shade", addProducer("field", "field"), target);
    ASSERT_TRUE(graph().compile());
    run();
    ASSERT_EQ(graph().collectTimings().size(), 2u);

    graph().reset();
    target = graph().importTexture("target", targetTex, Access::ColorTarget);
    for (int i = 0; i < 40; ++i)
        graph().addPass<Empty>(
            "pass" + std::to_string(i), PassKind::Compute, [](PassBuilder& b, Empty&) { b.sideEffect(); },
            [](const Empty&, PassContext& ctx) { dispatch(ctx, 1); });
    TextureRef field = addProducer("field", "field");
    addShadePass("shade", field, target);
    ASSERT_TRUE(graph().compile());
    run();
    auto timings = graph().collectTimings();
    ASSERT_EQ(timings.size(), 42u);
    for (const auto& t : timings) EXPECT_GE(t.gpuMs, 0.0) << t.name;
}

TEST_F(FrameGraphTest, GraphvizShowsPassesResourcesAndCulling) {
    TextureRef target = graph().importTexture("backbuffer", makeTexture("bb"), Access::None, Access::Present);
    TextureRef field = addProducer("trace \"primary\"", "gbuffer");
    addProducer("debugSlices", "slices");
    addShadePass("lighting", field, target);
    ASSERT_TRUE(graph().compile());
    std::string dot = graph().toGraphviz();
    EXPECT_EQ(dot.rfind("digraph", 0), 0u);
    EXPECT_NE(dot.find("trace \\\"primary\\\""), std::string::npos) << dot;  // quotes escaped
    EXPECT_NE(dot.find("lighting"), std::string::npos);
    EXPECT_NE(dot.find("debugSlices"), std::string::npos);
    EXPECT_NE(dot.find("(culled)"), std::string::npos);
    EXPECT_NE(dot.find("dashed"), std::string::npos);
    EXPECT_NE(dot.find("imported"), std::string::npos);
    EXPECT_NE(dot.find("(not allocated)"), std::string::npos);
    EXPECT_NE(dot.find("ShaderSampled"), std::string::npos);
    EXPECT_NE(dot.find("ColorTarget"), std::string::npos);
    // Exactly one culled pass node.
    size_t culled = 0;
    for (size_t p = dot.find("(culled)"); p != std::string::npos; p = dot.find("(culled)", p + 1)) ++culled;
    EXPECT_EQ(culled, 1u);
    EXPECT_EQ(dot.back(), '\n');
    run();
}

// ---------------------------------------------------------------------------------------------
// Errors: reported through the log, compile() false, execute() records nothing, no crash.
// ---------------------------------------------------------------------------------------------
class FrameGraphErrorTest : public FrameGraphTest {
protected:
    // Compiles, executes and submits; expects failure with `errors` logged and nothing recorded.
    void expectFailedFrame(size_t errors) {
        EXPECT_FALSE(graph().compile());
        EXPECT_TRUE(graph().hasErrors());
        Commands cmds = run();
        EXPECT_TRUE(cmds.empty()) << cmds.size() << " commands recorded";
        EXPECT_TRUE(graph().collectTimings().empty());
        EXPECT_EQ(m_graphErrors.size(), errors);
        for (const std::string& e : m_graphErrors) EXPECT_NE(e.find("frame graph"), std::string::npos) << e;
        m_graphErrors.clear();
    }
};

TEST_F(FrameGraphErrorTest, WritingAResourceThatWasNeverCreated) {
    bool ran = false;
    graph().addPass<Empty>(
        "bad", PassKind::Compute,
        [](PassBuilder& b, Empty&) {
            b.write(TextureRef{}, Access::ShaderWrite);
            b.write(BufferRef{7, 1}, Access::ShaderWrite);
            b.sideEffect();
        },
        [&](const Empty&, PassContext&) { ran = true; });
    expectFailedFrame(2);
    EXPECT_FALSE(ran);
}

TEST_F(FrameGraphErrorTest, ReadingATransientBeforeAnyWrite) {
    graph().addPass<TexData>(
        "early", PassKind::Compute,
        [](PassBuilder& b, TexData& d) {
            d.tex = b.read(b.createTexture("fresh", colorDesc()), Access::ShaderSampled);
            b.sideEffect();
        },
        [](const TexData&, PassContext&) {});
    expectFailedFrame(1);
}

TEST_F(FrameGraphErrorTest, IncompatibleUsagesInOnePass) {
    TextureRef field = addProducer("field", "field");
    graph().addPass<TexData>(
        "feedback", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            d.tex = b.read(field, Access::ShaderSampled);
            b.write(field, Access::ShaderWrite);
            b.sideEffect();
        },
        [](const TexData&, PassContext&) {});
    expectFailedFrame(1);
}

TEST_F(FrameGraphErrorTest, WrongAccessKinds) {
    TextureRef field = addProducer("field", "field");
    graph().addPass<Empty>(
        "misuse", PassKind::Compute,
        [&](PassBuilder& b, Empty&) {
            b.read(field, Access::ShaderWrite);   // a write declared as a read
            b.write(field, Access::ShaderRead);   // a read declared as a write
            b.read(field, Access::VertexRead);    // not a texture access
            b.write(field, Access::ColorTarget);  // attachment in a compute pass
            b.read(field, Access::None);          // nothing
            b.sideEffect();
        },
        [](const Empty&, PassContext&) {});
    expectFailedFrame(5);
}

TEST_F(FrameGraphErrorTest, CompileTwice) {
    TextureRef target =
        graph().importTexture("target", makeTexture("target", Access::ColorTarget), Access::ColorTarget);
    TextureRef field = addProducer("field", "field");
    addShadePass("shade", field, target);
    ASSERT_TRUE(graph().compile());
    expectFailedFrame(1);
}

TEST_F(FrameGraphErrorTest, StaleRefsFromAPreviousFrameAndBadImports) {
    TextureRef old = addProducer("field", "field");
    graph().markOutput(old);
    ASSERT_TRUE(graph().compile());
    run();
    graph().reset();
    graph().addPass<Empty>(
        "stale", PassKind::Compute,
        [&](PassBuilder& b, Empty&) {
            b.read(old, Access::ShaderSampled);
            b.sideEffect();
        },
        [](const Empty&, PassContext&) {});
    TextureRef bad = graph().importTexture("dead", rhi::TextureHandle{}, Access::None);
    EXPECT_FALSE(bad.isValid());
    rhi::TextureHandle t = makeTexture("twice");
    graph().importTexture("first", t, Access::None);
    EXPECT_FALSE(graph().importTexture("second", t, Access::None).isValid());
    expectFailedFrame(3);

    // The graph recovers on the next frame.
    graph().reset();
    TextureRef target = graph().importTexture("target", t, Access::None, Access::ColorTarget);
    TextureRef field = addProducer("field", "field");
    addShadePass("shade", field, target);
    EXPECT_TRUE(graph().compile());
    EXPECT_FALSE(run().empty());
    EXPECT_TRUE(m_graphErrors.empty());
}

TEST_F(FrameGraphErrorTest, UndeclaredResourceInExecuteAndMissingImportUsage) {
    TextureRef target =
        graph().importTexture("target", makeTexture("target", Access::ColorTarget), Access::ColorTarget);
    TextureRef field = addProducer("field", "field");
    TextureRef other = addProducer("other", "other");
    graph().markOutput(other);
    graph().addPass<TwoTex>(
        "sneaky", PassKind::Raster,
        [&](PassBuilder& b, TwoTex& d) {
            d.in = other;  // not declared by this pass
            d.out = b.write(target, Access::ColorTarget);
            b.read(field, Access::ShaderSampled);
        },
        [](const TwoTex& d, PassContext& ctx) { EXPECT_FALSE(ctx.texture(d.in).isValid()); });
    ASSERT_TRUE(graph().compile());
    run();
    EXPECT_EQ(m_graphErrors.size(), 1u);
    m_graphErrors.clear();

    // An import whose texture lacks the usage a pass declares.
    graph().reset();
    rhi::TextureDesc d = colorDesc();
    d.usage = rhi::TextureUsage::Sampled;
    rhi::TextureHandle sampledOnly = dev().createTexture(d);
    TextureRef imp = graph().importTexture("sampledOnly", sampledOnly, Access::None);
    graph().addPass<TexData>(
        "store", PassKind::Compute,
        [&](PassBuilder& b, TexData& td) { td.tex = b.write(imp, Access::ShaderWrite); },
        [](const TexData&, PassContext&) {});
    expectFailedFrame(1);
    dev().destroy(sampledOnly);
}

TEST_F(FrameGraphErrorTest, ExecuteBeforeCompileAndAddPassAfterCompile) {
    TextureRef field = addProducer("field", "field");
    graph().markOutput(field);
    Commands cmds = run();  // not compiled
    EXPECT_TRUE(cmds.empty());
    EXPECT_EQ(m_graphErrors.size(), 1u);
    m_graphErrors.clear();

    graph().reset();
    TextureRef f2 = addProducer("field", "field");
    graph().markOutput(f2);
    ASSERT_TRUE(graph().compile());
    addProducer("late", "late");
    EXPECT_EQ(m_graphErrors.size(), 1u);
    EXPECT_TRUE(run().empty());
    m_graphErrors.clear();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Subresources: mip levels, array layers, 3D boxes
// ---------------------------------------------------------------------------------------------
using penumbra::fg::Subresource;

namespace subres {

bool sameRangedBarrier(const rhi::Barrier& a, const rhi::Barrier& b) {
    return sameBarrier(a, b) && a.range == b.range;
}

rhi::TextureRange mipRange(uint32_t mip, uint32_t count = 1) { return {mip, count, 0, rhi::kRemaining}; }

}  // namespace subres

// A mip chain as a sequence of passes, each sampling mip i-1 and writing mip i of one transient:
// every step gets exactly the barriers of the two mips it touches, no pass has a hand-written
// barrier, and a final reader of the whole chain transitions all mips in one merged barrier.
TEST_F(FrameGraphTest, MipChainStepsGetPerMipBarriers) {
    using subres::mipRange;
    using subres::sameRangedBarrier;
    rhi::TextureDesc desc = colorDesc(64, 64);
    desc.mipLevels = 4;
    TextureRef target =
        graph().importTexture("target", makeTexture("target", Access::ColorTarget), Access::ColorTarget);
    TextureRef chain;
    graph().addPass<TexData>(
        "mip0", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            chain = d.tex =
                b.write(b.createTexture("chain", desc), Access::ShaderWrite, Subresource::mips(0));
        },
        [](const TexData&, PassContext& ctx) { dispatch(ctx, 8, 8); });
    for (uint32_t m = 1; m < 4; ++m) {
        graph().addPass<TexData>(
            "down" + std::to_string(m), PassKind::Compute,
            [&](PassBuilder& b, TexData& d) {
                b.read(chain, Access::ShaderSampled, Subresource::mips(m - 1));
                d.tex = b.write(chain, Access::ShaderWrite, Subresource::mips(m));
            },
            [](const TexData&, PassContext& ctx) { dispatch(ctx, 4, 4); });
    }
    addShadePass("use", chain, target);
    ASSERT_TRUE(graph().compile()) << (m_graphErrors.empty() ? "" : m_graphErrors[0]);
    EXPECT_TRUE(graph().compiled().culledPasses.empty());
    const rhi::TextureHandle t = graph().physicalTexture(chain);

    const auto* mip0 = graph().compiled().findPass("mip0");
    ASSERT_EQ(mip0->barriers.size(), 1u);
    EXPECT_TRUE(sameRangedBarrier(mip0->barriers[0],
                                  rhi::Barrier::tex(t, Access::None, Access::ShaderWrite, mipRange(0))));
    for (uint32_t m = 1; m < 4; ++m) {
        const auto* down = graph().compiled().findPass("down" + std::to_string(m));
        ASSERT_NE(down, nullptr);
        ASSERT_EQ(down->barriers.size(), 2u) << "down" << m;
        EXPECT_TRUE(sameRangedBarrier(
            down->barriers[0],
            rhi::Barrier::tex(t, Access::ShaderWrite, Access::ShaderSampled, mipRange(m - 1))))
            << "down" << m;
        EXPECT_TRUE(sameRangedBarrier(down->barriers[1],
                                      rhi::Barrier::tex(t, Access::None, Access::ShaderWrite, mipRange(m))))
            << "down" << m;
    }
    // mips 0..2 are already sampled; only mip 3 changes state, as one barrier.
    const auto* use = graph().compiled().findPass("use");
    std::vector<rhi::Barrier> onChain;
    for (const rhi::Barrier& b : use->barriers)
        if (b.texture == t) onChain.push_back(b);
    ASSERT_EQ(onChain.size(), 1u);
    EXPECT_TRUE(sameRangedBarrier(
        onChain[0], rhi::Barrier::tex(t, Access::ShaderWrite, Access::ShaderSampled, mipRange(3))));
    EXPECT_TRUE(m_graphErrors.empty());
}

// Whole-texture uses of a texture whose mips are in different states: one barrier per run of
// mips in one state (consecutive mips merged), none for mips already in the needed state.
TEST_F(FrameGraphTest, WholeTextureUseAfterPartialWritesMergesMipRuns) {
    using subres::mipRange;
    using subres::sameRangedBarrier;
    rhi::TextureDesc desc = colorDesc(32, 32);
    desc.mipLevels = 5;
    TextureRef target =
        graph().importTexture("target", makeTexture("target", Access::ColorTarget), Access::ColorTarget);
    TextureRef tex;
    graph().addPass<TexData>(
        "all", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            tex = d.tex = b.write(b.createTexture("t", desc), Access::ShaderWrite);
        },
        [](const TexData&, PassContext& ctx) { dispatch(ctx, 1); });
    graph().addPass<TexData>(
        "sample_low", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            d.tex = b.read(tex, Access::ShaderSampled, Subresource::mips(0, 2));
            b.write(b.createTexture("sink", colorDesc(4, 4)), Access::ShaderWrite);
            b.sideEffect();
        },
        [](const TexData&, PassContext& ctx) { dispatch(ctx, 1); });
    addShadePass("use", tex, target);
    ASSERT_TRUE(graph().compile()) << (m_graphErrors.empty() ? "" : m_graphErrors[0]);
    const rhi::TextureHandle t = graph().physicalTexture(tex);
    const auto* low = graph().compiled().findPass("sample_low");
    std::vector<rhi::Barrier> onTex;
    for (const rhi::Barrier& b : low->barriers)
        if (b.texture == t) onTex.push_back(b);
    ASSERT_EQ(onTex.size(), 1u);
    EXPECT_TRUE(sameRangedBarrier(
        onTex[0], rhi::Barrier::tex(t, Access::ShaderWrite, Access::ShaderSampled, mipRange(0, 2))));
    const auto* use = graph().compiled().findPass("use");
    onTex.clear();
    for (const rhi::Barrier& b : use->barriers)
        if (b.texture == t) onTex.push_back(b);
    ASSERT_EQ(onTex.size(), 1u);
    EXPECT_TRUE(sameRangedBarrier(
        onTex[0], rhi::Barrier::tex(t, Access::ShaderWrite, Access::ShaderSampled, mipRange(2, 3))));
}

// Array layers: writing one layer of an imported array and reading it back gives barriers on
// that layer only; at the end of the frame only that layer returns to the import's state.
TEST_F(FrameGraphTest, ArrayLayerWritesAreTrackedPerLayer) {
    using subres::sameRangedBarrier;
    rhi::TextureDesc d = colorDesc(16, 16);
    d.dimension = rhi::TextureDimension::Tex2DArray;
    d.depthOrLayers = 4;
    d.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::Storage | rhi::TextureUsage::CopySrc;
    d.debugName = "layers";
    rhi::TextureHandle handle = dev().createTexture(d);
    ASSERT_TRUE(handle.isValid());
    TextureRef layers = graph().importTexture("layers", handle, Access::ShaderSampled);
    graph().addPass<TexData>(
        "write_layer2", PassKind::Compute,
        [&](PassBuilder& b, TexData& t) {
            t.tex = b.write(layers, Access::ShaderWrite, Subresource::layers(2));
        },
        [](const TexData&, PassContext& ctx) { dispatch(ctx, 1); });
    ASSERT_TRUE(graph().compile()) << (m_graphErrors.empty() ? "" : m_graphErrors[0]);
    const auto* w = graph().compiled().findPass("write_layer2");
    ASSERT_EQ(w->barriers.size(), 1u);
    EXPECT_TRUE(sameRangedBarrier(
        w->barriers[0], rhi::Barrier::tex(handle, Access::ShaderSampled, Access::ShaderWrite, {0, 1, 2, 1})));
    ASSERT_EQ(graph().compiled().finalBarriers.size(), 1u);
    EXPECT_TRUE(sameRangedBarrier(
        graph().compiled().finalBarriers[0],
        rhi::Barrier::tex(handle, Access::ShaderWrite, Access::ShaderSampled, {0, 1, 2, 1})));
    EXPECT_EQ(graph().finalState(layers), Access::ShaderSampled);
}

// 3D boxes: a box inside the mip is accepted (and its barrier covers the whole mip, as GPU image
// barriers do); two passes updating disjoint boxes of one field are ordered (WAW barrier).
TEST_F(FrameGraphTest, BoxUpdatesOf3DTextureAreOrdered) {
    using subres::mipRange;
    using subres::sameRangedBarrier;
    rhi::TextureDesc d;
    d.dimension = rhi::TextureDimension::Tex3D;
    d.format = rhi::Format::R16_FLOAT;
    d.width = d.height = d.depthOrLayers = 32;
    d.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::Storage;
    d.debugName = "field";
    rhi::TextureHandle handle = dev().createTexture(d);
    ASSERT_TRUE(handle.isValid());
    TextureRef field = graph().importTexture("field", handle, Access::ShaderSampled);
    for (uint32_t i = 0; i < 2; ++i)
        graph().addPass<TexData>(
            "update" + std::to_string(i), PassKind::Compute,
            [&](PassBuilder& b, TexData& t) {
                t.tex =
                    b.write(field, Access::ShaderWrite, Subresource::region(0, {16 * i, 0, 0}, {16, 32, 8}));
            },
            [](const TexData&, PassContext& ctx) { dispatch(ctx, 1); });
    ASSERT_TRUE(graph().compile()) << (m_graphErrors.empty() ? "" : m_graphErrors[0]);
    const auto* u1 = graph().compiled().findPass("update1");
    ASSERT_EQ(u1->barriers.size(), 1u);
    EXPECT_TRUE(sameRangedBarrier(u1->barriers[0],
                                  rhi::Barrier::tex(handle, Access::ShaderWrite, Access::ShaderWrite)));
    EXPECT_NE(graph().toGraphviz().find("box (16,0,0) size (16,32,8)"), std::string::npos);
}

TEST_F(FrameGraphErrorTest, SubresourceOutsideTheTextureAndOverlappingIncompatibleParts) {
    using penumbra::fg::Subresource;
    rhi::TextureDesc desc = colorDesc(16, 16);
    desc.mipLevels = 2;
    graph().addPass<TexData>(
        "bad_mip", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            d.tex = b.write(b.createTexture("t", desc), Access::ShaderWrite, Subresource::mips(2));
        },
        [](const TexData&, PassContext&) {});
    ASSERT_EQ(m_graphErrors.size(), 1u);
    EXPECT_NE(m_graphErrors[0].find("outside the texture"), std::string::npos) << m_graphErrors[0];

    graph().reset();
    m_graphErrors.clear();
    TextureRef t;
    graph().addPass<TexData>(
        "init", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            t = d.tex = b.write(b.createTexture("t", desc), Access::ShaderWrite);
        },
        [](const TexData&, PassContext&) {});
    graph().addPass<TexData>(
        "overlap", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            b.read(t, Access::ShaderSampled, Subresource::mips(0, 2));
            d.tex = b.write(t, Access::ShaderWrite, Subresource::mips(1));
        },
        [](const TexData&, PassContext&) {});
    ASSERT_EQ(m_graphErrors.size(), 1u);
    EXPECT_NE(m_graphErrors[0].find("(mip 1, layer 0) with incompatible usages"), std::string::npos)
        << m_graphErrors[0];

    graph().reset();
    m_graphErrors.clear();
    graph().addPass<TexData>(
        "bad_box", PassKind::Compute,
        [&](PassBuilder& b, TexData& d) {
            d.tex = b.write(b.createTexture("t", desc), Access::ShaderWrite,
                            Subresource::region(1, {4, 0, 0}, {8, 8, 1}));
        },
        [](const TexData&, PassContext&) {});
    ASSERT_EQ(m_graphErrors.size(), 1u);
    EXPECT_NE(m_graphErrors[0].find("box (4,0,0) size (8,8,1)"), std::string::npos) << m_graphErrors[0];
}

// Timings come back from a ring of query pools without waiting: a 20-frame loop of 10 passes that
// polls every frame gets every frame exactly once (a few frames late at most), in order, and
// performs no blocking timestamp read; frames nobody polled while the ring wrapped are kept and
// returned later; flushTimings() returns what is left at the end of the run.
TEST_F(FrameGraphTest, TimingsArePolledFromARingWithoutBlocking) {
    const uint64_t blockingBefore = dev().stats().blockingTimestampReads;
    std::vector<penumbra::fg::FrameTimings> seen;
    std::vector<uint64_t> frames;
    for (int f = 0; f < 20; ++f) {
        graph().reset();
        frames.push_back(graph().frameNumber());
        for (int i = 0; i < 10; ++i)
            graph().addPass<Empty>(
                "pass" + std::to_string(i), PassKind::Compute, [](PassBuilder& b, Empty&) { b.sideEffect(); },
                [](const Empty&, PassContext& ctx) { dispatch(ctx, 1); });
        ASSERT_TRUE(graph().compile());
        run();
        // Frames 5..12 are not polled: the ring (kTimingFramesInFlight pools) wraps meanwhile.
        if (f < 5 || f > 12)
            for (auto& t : graph().pollTimings()) seen.push_back(std::move(t));
    }
    EXPECT_EQ(dev().stats().blockingTimestampReads, blockingBefore) << "a timestamp read waited in the loop";
    for (auto& t : graph().flushTimings()) seen.push_back(std::move(t));
    ASSERT_EQ(seen.size(), frames.size());
    for (size_t i = 0; i < seen.size(); ++i) {
        EXPECT_EQ(seen[i].frame, frames[i]);
        ASSERT_EQ(seen[i].passes.size(), 10u);
        EXPECT_EQ(seen[i].passes[9].name, "pass9");
        for (const auto& p : seen[i].passes) EXPECT_GE(p.gpuMs, 0.0) << p.name;
    }
    EXPECT_TRUE(graph().flushTimings().empty());
}
