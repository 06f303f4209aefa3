// The field atlas (issue 10, item 2): every object distance field (.psdf asset) a frame draws lives
// in ONE 3D texture, one box-shaped slot per asset id however many instances use it, described to
// the shaders by a GpuSdfField per slot (renderer/shaders/sdf_field.glsl reads both).
//
// Texel format. R16_FLOAT when the device samples and filters it in 3D, else R32_FLOAT (then at
// twice the memory; update() fails with an error when neither is filterable). R16F because it is
// half the memory of R32F and a distance field needs little precision: 11 significant bits, i.e.
// a relative step (ulp) of 2^-11 .. 2^-10 of the value. Values are stored in VOXEL units
// (distance / voxelSize; the shader multiplies back), so the precision does not depend on the
// mesh's units, no value is subnormal unless it is below 2^-14 voxel, and no consistent field is
// clamped: a field whose mesh lies in its grid has |d| <= the grid's diagonal, at most
// 16384 * sqrt(3) ~ 28378 voxels, below the half maximum 65504 (larger values are clamped to
// +-65504 voxels). The conversion rounds toward -infinity (toHalfTowardNegative; R32F likewise),
// so a stored value never exceeds the baked one: the rounding (< 1 ulp, i.e. < 2^-10 relative)
// only ever lowers a distance, which keeps the field conservative outside the surface.
//
// Sampling. The pass that reads the atlas creates its own sampler, which must be: linear min and
// mag filter, clamp-to-edge on u, v and w (rhi::SamplerDesc's defaults). Slots have no gap
// between them: sdf_field.glsl clamps sample positions to the slot's box of voxel centres shrunk by
// 1/64 texel, so the float rounding of the texel coordinate (~1e-7 of the atlas size, far below
// 1/64) never gives a texel of a neighbouring slot a non-zero filter weight; the interpolation
// bound includes the shrink. Never-written
// texels are zero (the texture is cleared when created), so a zero weight never meets a NaN.
//
// Packing: a guillotine allocator of free boxes (best fit by volume, the rest split in three boxes,
// freed boxes merged back with free neighbours that form a box). When a new field does not fit,
// every resident field is packed again (largest first) into the current size, then into ever larger
// sizes (sizes are multiples of 8 texels: the smallest axis grown by half, up to the device's
// maximum 3D texture size); a new texture is
// made when the size changes and the resident fields are uploaded again (logged at info level).
// Slot indices never change while their asset stays resident; texel positions may (fields() says
// where each one is now).
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/sdf/psdf.h"
#include "rhi/device.h"

namespace penumbra::render {

// One slot of the atlas as the shaders see it: std430 element of the storage buffer `SdfFields`
// (struct SdfField in renderer/shaders/sdf_field.glsl; tests/renderer/sdf_field_gpu_test.cpp
// static_asserts this layout against the shaderc-generated struct). 96 bytes.
struct GpuSdfField {
    glm::vec4 origin{0.0f};     // xyz: field-space position of voxel (0,0,0)'s CENTRE; w: voxel size
    glm::vec4 uvwScale{0.0f};   // xyz: 1 / (atlas size in texels); w: unused (0)
    glm::vec4 uvwOffset{0.0f};  // xyz: the slot's first texel (integers); w: unused (0)
    glm::vec4 dims{0.0f};       // xyz: voxels per axis (as floats); w: unused (0)
    glm::vec4 boundsMin{0.0f};  // xyz: source mesh bounds min (field space, rounded down); w: 1 when
                                // the mesh bounds lie inside the box of voxel centres (in double,
                                // as sdf::SdfSampler::meshInsideSampleBox), else 0
    glm::vec4 boundsMax{0.0f};  // xyz: source mesh bounds max (field space, rounded up); w: unused (0)
};
static_assert(sizeof(GpuSdfField) == 96, "GpuSdfField mirrors the std430 struct SdfField of sdf_field.glsl");

// `v` as an IEEE binary16 rounded toward -infinity (the largest half <= v), clamped to +-65504;
// NaN gives 0. Exposed for tests.
uint16_t toHalfTowardNegative(double v);
// `v` as a float rounded toward -infinity (the largest float <= v), clamped to +-FLT_MAX.
float toFloatTowardNegative(double v);

class SdfAtlas {
public:
    explicit SdfAtlas(rhi::Device& device);
    ~SdfAtlas();
    SdfAtlas(const SdfAtlas&) = delete;
    SdfAtlas& operator=(const SdfAtlas&) = delete;

    // Makes exactly these fields resident for this frame: one slot per asset id (a repeated id is
    // one slot); slots of ids not listed are freed and their space reused. A field is uploaded the
    // first time it is listed, or again when its id now names a different PsdfAsset object (a
    // replaced asset); the atlas grows as described above. The pointers need only be valid during
    // the call. False with `error` (and nothing changed: the previous frame's slots and texture
    // stay as they were) on a null or inconsistent asset (empty grid, distances.size() !=
    // voxel count, voxel size not positive and finite), a field larger than the device's maximum
    // 3D texture size, no filterable R16F / R32F 3D format, or a texture that cannot be created.
    // Uploads go through rhi::Device::writeTextureRegion, which orders them before the next
    // submission and leaves the texture in rhi::Access::ShaderSampled (a pass imports it in that
    // state).
    bool update(const std::vector<std::pair<assets::AssetId, const sdf::PsdfAsset*>>& fields,
                std::string& error);

    // Index into fields() of the asset's slot; UINT32_MAX when it is not resident.
    uint32_t slotOf(assets::AssetId id) const;
    // Per slot index (stable while the asset stays resident). A free slot's entry is all zeros.
    const std::vector<GpuSdfField>& fields() const { return m_gpuFields; }
    // The atlas (R16_FLOAT or R32_FLOAT, Tex3D, one mip; usage Sampled | CopyDst | CopySrc). Null
    // until a field is first made resident; kept (all free) when a frame lists none.
    rhi::TextureHandle texture() const { return m_texture; }
    rhi::Format format() const { return m_format; }
    glm::uvec3 size() const { return m_size; }  // texels per axis (0 while there is no texture)
    uint64_t bytes() const;                     // texture bytes (rhi::textureBytes)
    double fill() const;                        // voxels of resident fields / texels of the texture
    uint32_t residentCount() const { return uint32_t(m_resident.size()); }
    uint64_t uploads() const { return m_uploads; }  // fields uploaded since creation (re-uploads too)
    uint32_t growths() const { return m_growths; }  // textures made larger since creation

private:
    struct Box {
        glm::uvec3 pos{0}, size{0};
    };
    struct Resident {
        uint32_t slot = 0;
        Box box;
        const sdf::PsdfAsset* source = nullptr;
    };
    struct Pending {  // a field to upload at the end of update()
        assets::AssetId id = 0;
        const sdf::PsdfAsset* asset = nullptr;
    };

    bool chooseFormat(std::string& error);
    static bool largerField(const Pending& a, const Pending& b);
    bool collectWanted(const std::vector<std::pair<assets::AssetId, const sdf::PsdfAsset*>>& fields,
                       std::vector<Pending>& wanted,
                       std::unordered_map<assets::AssetId, const sdf::PsdfAsset*>& seen,
                       std::string& error) const;
    bool packAll(const std::vector<Pending>& wanted, uint32_t max3D, glm::uvec3& size,
                 std::vector<Box>& freeBoxes, std::unordered_map<assets::AssetId, Box>& placed,
                 std::string& error) const;
    bool replaceTexture(const glm::uvec3& size, size_t fieldCount, std::string& error);
    static bool allocate(std::vector<Box>& freeBoxes, const glm::uvec3& size, Box& out);
    static void release(std::vector<Box>& freeBoxes, const Box& box);
    bool upload(const Resident& r, const sdf::PsdfAsset& asset, std::string& error);
    GpuSdfField describe(const Box& box, const sdf::PsdfAsset& asset) const;

    rhi::Device& m_device;
    rhi::Format m_format = rhi::Format::Undefined;
    rhi::TextureHandle m_texture;
    glm::uvec3 m_size{0};
    std::vector<Box> m_free;  // free boxes of the current texture
    std::unordered_map<assets::AssetId, Resident> m_resident;
    std::vector<GpuSdfField> m_gpuFields;
    std::vector<uint32_t> m_freeSlots;
    uint64_t m_residentVoxels = 0;
    uint64_t m_uploads = 0;
    uint32_t m_growths = 0;
};

}  // namespace penumbra::render
