#include "renderer/features/sdf_scene.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <glm/mat3x3.hpp>

#include <shaders/sdf_trace.h>

#include "renderer/features/scene_upload.h"
#include "renderer/features/sdf_atlas.h"

namespace penumbra::render {
namespace {

namespace program = shaders::sdf_trace;
static_assert(sizeof(GpuSdfObject) == sizeof(program::SdfObject));
static_assert(offsetof(GpuSdfObject, boundsMin) == offsetof(program::SdfObject, boundsMin));
static_assert(offsetof(GpuSdfObject, info) == offsetof(program::SdfObject, info));
static_assert(offsetof(GpuSdfObject, params) == offsetof(program::SdfObject, params));
static_assert(sizeof(sdf::ShapeInstruction) == sizeof(program::ShapeInstruction));
static_assert(sizeof(GpuSdfField) == sizeof(program::SdfField));
static_assert(offsetof(GpuSdfField, boundsMin) == offsetof(program::SdfField, boundsMin));

}  // namespace

float smallestSingularValue(const glm::mat3& m) {
    // Eigenvalues of the symmetric A = m^T m by cyclic Jacobi rotations (double precision).
    double a[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double s = 0.0;
            for (int k = 0; k < 3; ++k) s += double(m[i][k]) * double(m[j][k]);  // column i . column j
            a[i][j] = s;
        }
    for (int sweep = 0; sweep < 50; ++sweep) {
        const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if (!(off > 1e-30 * (a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2]))) break;
        for (int p = 0; p < 2; ++p)
            for (int q = p + 1; q < 3; ++q) {
                if (a[p][q] == 0.0) continue;
                const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                const double t =
                    (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
                const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 3; ++k) {  // A <- A J (columns p, q)
                    const double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; ++k) {  // A <- J^T A (rows p, q)
                    const double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
            }
    }
    const double lambda = std::min({a[0][0], a[1][1], a[2][2]});
    if (!(lambda > 0.0) || !std::isfinite(lambda)) return 0.0f;
    // Rounded down by a few float ulps: exact uniform scales stay exact to float precision.
    return float(std::sqrt(lambda) * (1.0 - 4e-7));
}

void addSdfSceneUpload(FrameContext& fc, const SdfSceneData& data) {
    SdfSceneBuffers& out = fc.board.add<SdfSceneBuffers>();
    rhi::TextureHandle atlas = data.atlas;
    fg::TextureRef atlasRef;
    if (data.hasFields()) atlasRef = fc.graph.importTexture("sdf.atlas", atlas, rhi::Access::ShaderSampled);
    fc.graph.addPass<SdfSceneBuffers>(
        "sdf_upload", fg::PassKind::Transfer,
        [&](fg::PassBuilder& b, SdfSceneBuffers& d) {
            auto buffer = [&](const char* name, uint64_t size) {
                return uploadBuffer(b, name, size, d.bytes);
            };
            d.objects = buffer("sdf.objects", arrayBytes(data.objects));
            d.records = buffer("sdf.records", arrayBytes(data.records));
            if (data.hasFields()) {
                d.fields = buffer("sdf.fields", std::max<uint64_t>(data.fieldBytes, 16));
                d.atlas = atlasRef;
            }
            d.objectCount = uint32_t(data.objects.size());
            d.tracedCount = std::min(data.tracedCount, d.objectCount);
            out = d;
        },
        [&data](const SdfSceneBuffers& d, fg::PassContext& ctx) {
            updateArray(ctx.cmd, ctx.buffer(d.objects), data.objects);
            updateArray(ctx.cmd, ctx.buffer(d.records), data.records);
            if (data.hasFields() && data.fieldBytes > 0)
                updateChunked(ctx.cmd, ctx.buffer(d.fields), data.fields, data.fieldBytes);
        });
}

rhi::SamplerHandle sdfAtlasSampler(GpuCache& cache, const SdfSceneBuffers& sdf) {
    if (!sdf.atlas.isValid()) return {};
    rhi::SamplerDesc linear;  // trilinear, clamped (slots are sampled inside)
    linear.debugName = "sdf.atlas";
    return cache.sampler(linear);
}

void readSdfScene(fg::PassBuilder& b, const SdfSceneBuffers& sdf) {
    b.read(sdf.objects, rhi::Access::ShaderRead);
    b.read(sdf.records, rhi::Access::ShaderRead);
    if (sdf.atlas.isValid()) {
        b.read(sdf.fields, rhi::Access::ShaderRead);
        b.read(sdf.atlas, rhi::Access::ShaderSampled);
    }
}

void setSdfScene(ShaderParams& params, const fg::PassContext& ctx, const SdfSceneBuffers& sdf,
                 rhi::SamplerHandle atlasSampler) {
    params.set("SdfObjects", ctx.buffer(sdf.objects)).set("ShapeRecords", ctx.buffer(sdf.records));
    if (sdf.atlas.isValid())
        params.set("SdfFields", ctx.buffer(sdf.fields)).set("sdfAtlas", ctx.texture(sdf.atlas), atlasSampler);
}

}  // namespace penumbra::render
