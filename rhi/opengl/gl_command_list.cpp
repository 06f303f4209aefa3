// Command recording (GlCommandList) and its replay on the context at submit (GlDevice::exec*).
#include <algorithm>
#include <cstdio>
#include <cstring>

#include "rhi/common/subresource_states.h"
#include "rhi/opengl/gl_device.h"

namespace rhi::gl {

namespace {

std::string quoted(std::string_view name) {
    if (name.empty()) return "(unnamed)";
    std::string out;
    out.reserve(name.size() + 2);
    out += '\'';
    out.append(name.data(), name.size());
    out += '\'';
    return out;
}

// glMemoryBarrier bits that make writes visible to the accesses in `after`.
GLbitfield barrierBits(Access after, bool isTexture) {
    GLbitfield bits = 0;
    if (any(after & Access::ShaderSampled)) bits |= GL_TEXTURE_FETCH_BARRIER_BIT;
    if (any(after & (Access::ShaderRead | Access::ShaderWrite)))
        bits |= isTexture ? GL_SHADER_IMAGE_ACCESS_BARRIER_BIT : GL_SHADER_STORAGE_BARRIER_BIT;
    if (any(after & Access::UniformRead)) bits |= GL_UNIFORM_BARRIER_BIT;
    if (any(after & Access::VertexRead)) bits |= GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT;
    if (any(after & Access::IndexRead)) bits |= GL_ELEMENT_ARRAY_BARRIER_BIT;
    if (any(after & Access::IndirectRead)) bits |= GL_COMMAND_BARRIER_BIT;
    if (any(after & (Access::ColorTarget | Access::DepthTargetWrite | Access::DepthTargetRead)))
        bits |= GL_FRAMEBUFFER_BARRIER_BIT;
    if (any(after & (Access::CopySrc | Access::CopyDst)))
        bits |= GL_BUFFER_UPDATE_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT;
    if (any(after & Access::HostRead))
        bits |= GL_BUFFER_UPDATE_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT | GL_PIXEL_BUFFER_BARRIER_BIT |
                GL_CLIENT_MAPPED_BUFFER_BARRIER_BIT;
    return bits;
}

// GPU writes that need a glMemoryBarrier before later reads: every write access except host writes,
// which go through coherent persistent mappings.
constexpr Access kBarrierWrites = kWriteAccesses & ~Access::HostWrite;

}  // namespace

// ---------------------------------------------------------------------------------------------
// Recording
// ---------------------------------------------------------------------------------------------
void GlCommandList::begin(std::string_view name) {
    reset();
    m_name = name;
    m_recording = true;
}

void GlCommandList::reset() {
    m_commands.clear();
    m_name.clear();
    m_recording = false;
    m_inRenderPass = false;
    m_debugDepth = 0;
    m_pipeline.reset();
    m_passColorCount = 0;
    m_indexBound = false;
}

void GlCommandList::error(const std::string& message) const {
    m_device.error((m_name.empty() ? std::string() : "[" + m_name + "] ") + message);
}

void GlCommandList::barrier(std::span<const Barrier> barriers) {
    GLbitfield bits = 0;
    for (const Barrier& b : barriers) {
        if (b.buffer.isValid() == b.texture.isValid()) {
            error("barrier: exactly one of buffer / texture must be set");
            continue;
        }
        if (b.buffer && !m_device.m_buffers.contains(b.buffer)) {
            error("barrier: invalid or destroyed buffer handle");
            continue;
        }
        if (b.texture && !m_device.m_textures.contains(b.texture)) {
            error("barrier: invalid or destroyed texture handle");
            continue;
        }
        // glMemoryBarrier has no ranges: a barrier on some mips or layers orders the whole texture.
        TextureRange range;
        if (b.texture &&
            !detail::resolveRange(m_device.m_textures.get(b.texture)->get()->desc, b.range, range)) {
            error("barrier: the texture has no subresource range (base mip " +
                  std::to_string(b.range.baseMip) + ", base layer " + std::to_string(b.range.baseLayer) +
                  ") of that size");
            continue;
        }
        if (any(b.before & kBarrierWrites)) bits |= barrierBits(b.after, b.texture.isValid());
    }
    if (bits) m_commands.push_back([bits](GlDevice& d) { d.addBarrierBits(bits); });
}

void GlCommandList::updateBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) {
    BufferObj* b = m_device.buffer(dst, "updateBuffer");
    if (!b) return;
    if (!data || size == 0 || offset > b->desc.size || size > b->desc.size - offset) {
        error("updateBuffer " + quoted(b->desc.debugName) + ": range [" + std::to_string(offset) + ", +" +
              std::to_string(size) + ") is empty or exceeds the buffer's " + std::to_string(b->desc.size) +
              " bytes");
        return;
    }
    std::vector<uint8_t> bytes(static_cast<const uint8_t*>(data), static_cast<const uint8_t*>(data) + size);
    m_commands.push_back([name = b->name, offset, bytes = std::move(bytes)](GlDevice& d) {
        d.flushBarriers();
        d.m_gl.NamedBufferSubData(name, GLintptr(offset), GLsizeiptr(bytes.size()), bytes.data());
    });
}

void GlCommandList::copyBuffer(BufferHandle src, uint64_t srcOffset, BufferHandle dst, uint64_t dstOffset,
                               uint64_t size) {
    BufferObj* s = m_device.buffer(src, "copyBuffer (source)");
    BufferObj* t = m_device.buffer(dst, "copyBuffer (destination)");
    if (!s || !t) return;
    if (size == 0 || srcOffset > s->desc.size || size > s->desc.size - srcOffset ||
        dstOffset > t->desc.size || size > t->desc.size - dstOffset) {
        error("copyBuffer " + quoted(s->desc.debugName) + " -> " + quoted(t->desc.debugName) + ": " +
              std::to_string(size) + " bytes at " + std::to_string(srcOffset) + " -> " +
              std::to_string(dstOffset) + " is empty or out of range");
        return;
    }
    if (s == t && srcOffset < dstOffset + size && dstOffset < srcOffset + size) {
        error("copyBuffer " + quoted(s->desc.debugName) + ": source and destination ranges overlap");
        return;
    }
    m_commands.push_back([sn = s->name, tn = t->name, srcOffset, dstOffset, size](GlDevice& d) {
        d.flushBarriers();
        d.m_gl.CopyNamedBufferSubData(sn, tn, GLintptr(srcOffset), GLintptr(dstOffset), GLsizeiptr(size));
    });
}

void GlCommandList::fillBuffer(BufferHandle dst, uint64_t offset, uint64_t size, uint32_t value) {
    BufferObj* b = m_device.buffer(dst, "fillBuffer");
    if (!b) return;
    if (size == ~uint64_t(0) && offset < b->desc.size) size = (b->desc.size - offset) & ~uint64_t(3);
    if (size == 0 || offset % 4 != 0 || size % 4 != 0 || offset > b->desc.size ||
        size > b->desc.size - offset) {
        error("fillBuffer " + quoted(b->desc.debugName) + ": range [" + std::to_string(offset) + ", +" +
              std::to_string(size) + ") must be non-empty, 4-byte aligned and inside the buffer's " +
              std::to_string(b->desc.size) + " bytes");
        return;
    }
    m_commands.push_back([name = b->name, offset, size, value](GlDevice& d) {
        d.flushBarriers();
        d.m_gl.ClearNamedBufferSubData(name, GL_R32UI, GLintptr(offset), GLsizeiptr(size), GL_RED_INTEGER,
                                       GL_UNSIGNED_INT, &value);
    });
}

void GlCommandList::copyTexture(TextureHandle src, const TextureRegion& srcRegion, TextureHandle dst,
                                const TextureRegion& dstRegion) {
    TextureObj* s = m_device.texture(src, "copyTexture (source)");
    TextureObj* t = m_device.texture(dst, "copyTexture (destination)");
    if (!s || !t) return;
    TextureRegion a, b;
    std::string why;
    if (!detail::checkTextureCopy(s->desc, srcRegion, t->desc, dstRegion, s == t, a, b, why)) {
        error("copyTexture " + quoted(s->desc.debugName) + " -> " + quoted(t->desc.debugName) + ": " + why);
        return;
    }
    m_commands.push_back([sn = s->name, st = s->target, tn = t->name, tt = t->target, a, b](GlDevice& d) {
        d.flushBarriers();
        // z is the array layer for Tex2DArray (a.z and b.z are 0 there).
        d.m_gl.CopyImageSubData(sn, st, GLint(a.mip), GLint(a.x), GLint(a.y), GLint(a.z + a.layer), tn, tt,
                                GLint(b.mip), GLint(b.x), GLint(b.y), GLint(b.z + b.layer), GLsizei(a.width),
                                GLsizei(a.height), GLsizei(a.depth));
    });
}

void GlCommandList::copyBufferToTexture(BufferHandle src, uint64_t srcOffset, TextureHandle dst,
                                        const TextureRegion& dstRegion) {
    BufferObj* s = m_device.buffer(src, "copyBufferToTexture (source)");
    TextureObj* t = m_device.texture(dst, "copyBufferToTexture (destination)");
    if (!s || !t) return;
    TextureRegion box;
    std::string why;
    if (!detail::checkBufferToTexture(s->desc.size, srcOffset, t->desc, dstRegion, box, why)) {
        error("copyBufferToTexture " + quoted(s->desc.debugName) + " -> " + quoted(t->desc.debugName) + ": " +
              why);
        return;
    }
    // GL names stay valid until the submission completes (deferred destruction): copy what replay needs.
    m_commands.push_back([tex = *t, buffer = s->name, srcOffset, box](GlDevice& d) {
        d.flushBarriers();
        d.m_gl.BindBuffer(GL_PIXEL_UNPACK_BUFFER, buffer);
        d.uploadRegion(tex, box, reinterpret_cast<const void*>(uintptr_t(srcOffset)));
        d.m_gl.BindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    });
}

void GlCommandList::bindPipeline(PipelineHandle pipeline) {
    auto* p = m_device.m_pipelines.get(pipeline);
    if (!p) {
        error("bindPipeline: invalid or destroyed pipeline handle");
        return;
    }
    std::shared_ptr<PipelineObj> obj = *p;
    if (obj->graphics && m_inRenderPass && obj->colorFormats.size() != m_passColorCount) {
        error("bindPipeline " + quoted(obj->debugName) + ": the pipeline has " +
              std::to_string(obj->colorFormats.size()) + " colour targets, the render pass " +
              std::to_string(m_passColorCount));
        return;
    }
    m_pipeline = obj;
    m_commands.push_back([obj](GlDevice& d) { d.execBindPipeline(obj); });
}

void GlCommandList::bindGroup(uint32_t set, BindGroupHandle group) {
    auto* g = m_device.m_bindGroups.get(group);
    if (!g) {
        error("bindGroup: invalid or destroyed bind group handle");
        return;
    }
    if (set >= kMaxBindGroups || (*g)->set != set) {
        error("bindGroup: bind group " + quoted((*g)->debugName) + " was created for set " +
              std::to_string((*g)->set) + " but is bound to set " + std::to_string(set));
        return;
    }
    m_commands.push_back([set, obj = *g](GlDevice& d) {
        d.m_rs.groups[set] = obj;
        d.m_rs.bindingsDirty = true;
    });
}

void GlCommandList::pushConstants(const void* data, uint32_t size, uint32_t offset) {
    if (!data || size == 0 || offset > kMaxPushConstantSize || size > kMaxPushConstantSize - offset) {
        error("pushConstants: range [" + std::to_string(offset) + ", +" + std::to_string(size) +
              ") is empty or exceeds " + std::to_string(kMaxPushConstantSize) + " bytes");
        return;
    }
    std::array<uint8_t, kMaxPushConstantSize> bytes{};
    std::memcpy(bytes.data(), data, size);
    m_commands.push_back([bytes, size, offset](GlDevice& d) {
        d.m_gl.NamedBufferSubData(d.m_pushConstantUbo, GLintptr(offset), GLsizeiptr(size), bytes.data());
    });
}

void GlCommandList::dispatch(uint32_t groupsX, uint32_t groupsY, uint32_t groupsZ) {
    if (!m_pipeline || m_pipeline->graphics) {
        error("dispatch: no compute pipeline is bound");
        return;
    }
    if (m_inRenderPass) {
        error("dispatch: not allowed inside a render pass");
        return;
    }
    const auto& maxCount = m_device.m_info.limits.maxComputeWorkgroupCount;
    if (groupsX > maxCount[0] || groupsY > maxCount[1] || groupsZ > maxCount[2]) {
        error("dispatch " + quoted(m_pipeline->debugName) +
              ": group count exceeds GL_MAX_COMPUTE_WORK_GROUP_COUNT");
        return;
    }
    if (groupsX == 0 || groupsY == 0 || groupsZ == 0) return;
    m_commands.push_back([groupsX, groupsY, groupsZ](GlDevice& d) {
        d.flushBarriers();
        d.applyBindings();
        d.m_gl.DispatchCompute(groupsX, groupsY, groupsZ);
    });
}

bool GlCommandList::checkIndirectBuffer(BufferHandle args, uint64_t offset, uint64_t bytes, const char* what,
                                        GLuint& name) const {
    BufferObj* b = m_device.buffer(args, what);
    if (!b) return false;
    if (!any(b->desc.usage & BufferUsage::Indirect)) {
        error(std::string(what) + ": buffer " + quoted(b->desc.debugName) + " lacks BufferUsage::Indirect");
        return false;
    }
    if (offset % 4 != 0 || offset > b->desc.size || bytes > b->desc.size - offset) {
        error(std::string(what) + ": " + std::to_string(bytes) + " argument bytes at offset " +
              std::to_string(offset) + " are misaligned or exceed buffer " + quoted(b->desc.debugName));
        return false;
    }
    name = b->name;
    return true;
}

void GlCommandList::dispatchIndirect(BufferHandle args, uint64_t offset) {
    if (!m_pipeline || m_pipeline->graphics) {
        error("dispatchIndirect: no compute pipeline is bound");
        return;
    }
    if (m_inRenderPass) {
        error("dispatchIndirect: not allowed inside a render pass");
        return;
    }
    GLuint name = 0;
    if (!checkIndirectBuffer(args, offset, 12, "dispatchIndirect", name)) return;
    m_commands.push_back([name, offset](GlDevice& d) {
        d.flushBarriers();
        d.applyBindings();
        d.m_gl.BindBuffer(GL_DISPATCH_INDIRECT_BUFFER, name);
        d.m_gl.DispatchComputeIndirect(GLintptr(offset));
        d.m_gl.BindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
    });
}

void GlCommandList::beginRenderPass(const RenderPassDesc& desc) {
    const std::string what = "beginRenderPass " + quoted(desc.debugName);
    if (m_inRenderPass) {
        error(what + ": a render pass is already active");
        return;
    }
    if (desc.colorAttachments.empty() && !desc.depthAttachment.texture) {
        error(what + ": the pass has no attachments");
        return;
    }
    if (desc.colorAttachments.size() > m_device.m_info.limits.maxColorTargets) {
        error(what + ": too many colour attachments");
        return;
    }
    RenderPassRecord pass;
    pass.debugName = desc.debugName;
    bool sizeSet = false, ok = true;
    auto resolve = [&](TextureHandle h, uint32_t mip, uint32_t layer, bool depth, AttachmentRef& ref) {
        TextureObj* t = m_device.texture(
            h, depth ? "beginRenderPass (depth attachment)" : "beginRenderPass (colour attachment)");
        if (!t) return false;
        const TextureDesc& td = t->desc;
        const TextureUsage need = depth ? TextureUsage::DepthTarget : TextureUsage::ColorTarget;
        if (!any(td.usage & need)) {
            error(what + ": texture " + quoted(td.debugName) + " lacks " +
                  (depth ? "TextureUsage::DepthTarget" : "TextureUsage::ColorTarget"));
            return false;
        }
        if (mip >= td.mipLevels) {
            error(what + ": mip " + std::to_string(mip) + " of " + quoted(td.debugName) + " is out of range");
            return false;
        }
        const uint32_t w = std::max(1u, td.width >> mip), h2 = std::max(1u, td.height >> mip);
        const uint32_t layers = td.dimension == TextureDimension::Tex2DArray ? td.depthOrLayers
                                : td.dimension == TextureDimension::Tex3D
                                    ? std::max(1u, td.depthOrLayers >> mip)
                                    : 1;
        if (layer >= layers) {
            error(what + ": layer " + std::to_string(layer) + " of " + quoted(td.debugName) +
                  " is out of range");
            return false;
        }
        if (!sizeSet) {
            pass.width = w;
            pass.height = h2;
            sizeSet = true;
        } else if (pass.width != w || pass.height != h2) {
            error(what + ": attachments differ in size (" + std::to_string(w) + "x" + std::to_string(h2) +
                  " vs " + std::to_string(pass.width) + "x" + std::to_string(pass.height) + ")");
            return false;
        }
        ref.texture = t->name;
        ref.layered = td.dimension != TextureDimension::Tex2D;
        ref.mip = mip;
        ref.layer = layer;
        ref.format = td.format;
        return true;
    };
    for (const ColorAttachment& c : desc.colorAttachments) {
        AttachmentRef ref;
        if (!resolve(c.texture, c.mip, c.layer, false, ref)) {
            ok = false;
            break;
        }
        ref.load = c.load;
        ref.store = c.store;
        ref.clearColor = c.clearColor;
        pass.colors.push_back(ref);
    }
    if (ok && desc.depthAttachment.texture) {
        const DepthAttachment& da = desc.depthAttachment;
        ok = resolve(da.texture, 0, 0, true, pass.depth);
        pass.hasDepth = ok;
        pass.depth.load = da.load;
        pass.depth.store = da.store;
        pass.clearDepth = da.clearDepth;
        pass.depthReadOnly = da.readOnly;
    }
    // The pass still opens (so endRenderPass pairs up), but draws inside an invalid one are dropped.
    m_inRenderPass = true;
    m_passColorCount = uint32_t(desc.colorAttachments.size());
    if (!ok) {
        m_commands.push_back([](GlDevice& d) {
            d.m_rs.inPass = true;
            d.m_rs.passValid = false;
        });
        return;
    }
    m_commands.push_back([pass = std::move(pass)](GlDevice& d) { d.execBeginRenderPass(pass); });
}

void GlCommandList::endRenderPass() {
    if (!m_inRenderPass) {
        error("endRenderPass: no render pass is active");
        return;
    }
    m_inRenderPass = false;
    m_passColorCount = 0;
    m_commands.push_back([](GlDevice& d) { d.execEndRenderPass(); });
}

void GlCommandList::setViewport(const Viewport& vp) {
    if (!(vp.width > 0.0f) || !(vp.height > 0.0f)) {
        error("setViewport: width and height must be positive (negative-height flips are not supported)");
        return;
    }
    m_commands.push_back([vp](GlDevice& d) {
        d.m_gl.ViewportIndexedf(0, vp.x, vp.y, vp.width, vp.height);
        d.m_gl.DepthRangeIndexed(0, double(vp.minDepth), double(vp.maxDepth));
    });
}

void GlCommandList::setScissor(const Rect& rect) {
    if (rect.x < 0 || rect.y < 0) {
        error("setScissor: the offset must not be negative");
        return;
    }
    m_commands.push_back([rect](GlDevice& d) {
        d.m_gl.ScissorIndexed(0, rect.x, rect.y, GLsizei(std::min<uint32_t>(rect.width, 0x7fffffff)),
                              GLsizei(std::min<uint32_t>(rect.height, 0x7fffffff)));
    });
}

void GlCommandList::bindVertexBuffer(uint32_t slot, BufferHandle buffer, uint64_t offset) {
    BufferObj* b = m_device.buffer(buffer, "bindVertexBuffer");
    if (!b) return;
    if (slot >= 16) {
        error("bindVertexBuffer: slot " + std::to_string(slot) + " is out of range");
        return;
    }
    if (!any(b->desc.usage & BufferUsage::Vertex)) {
        error("bindVertexBuffer: buffer " + quoted(b->desc.debugName) + " lacks BufferUsage::Vertex");
        return;
    }
    if (offset >= b->desc.size) {
        error("bindVertexBuffer: offset " + std::to_string(offset) + " is outside buffer " +
              quoted(b->desc.debugName));
        return;
    }
    m_commands.push_back([slot, name = b->name, offset](GlDevice& d) {
        d.m_rs.vertexBuffers[slot] = {name, GLintptr(offset)};
        d.m_rs.vertexDirty = true;
    });
}

void GlCommandList::bindIndexBuffer(BufferHandle buffer, IndexType type, uint64_t offset) {
    BufferObj* b = m_device.buffer(buffer, "bindIndexBuffer");
    if (!b) return;
    if (!any(b->desc.usage & BufferUsage::Index)) {
        error("bindIndexBuffer: buffer " + quoted(b->desc.debugName) + " lacks BufferUsage::Index");
        return;
    }
    const uint64_t indexSize = type == IndexType::Uint16 ? 2 : 4;
    if (offset >= b->desc.size || offset % indexSize != 0) {
        error("bindIndexBuffer: offset " + std::to_string(offset) + " is misaligned or outside buffer " +
              quoted(b->desc.debugName));
        return;
    }
    m_indexBound = true;
    m_commands.push_back([name = b->name, type, offset](GlDevice& d) {
        d.m_rs.indexBuffer = name;
        d.m_rs.indexType = type == IndexType::Uint16 ? GL_UNSIGNED_SHORT : GL_UNSIGNED_INT;
        d.m_rs.indexOffset = offset;
        d.m_rs.indexDirty = true;
    });
}

bool GlCommandList::checkGraphicsDraw(const char* what) const {
    if (!m_inRenderPass) {
        error(std::string(what) + ": not inside a render pass");
        return false;
    }
    if (!m_pipeline || !m_pipeline->graphics) {
        error(std::string(what) + ": no graphics pipeline is bound");
        return false;
    }
    return true;
}

void GlCommandList::draw(uint32_t vertexCount, uint32_t instanceCount, uint32_t firstVertex,
                         uint32_t firstInstance) {
    if (!checkGraphicsDraw("draw")) return;
    if (vertexCount == 0 || instanceCount == 0) return;
    m_commands.push_back([=](GlDevice& d) {
        if (!d.prepareDraw()) return;
        const PipelineObj& p = *d.m_rs.pipeline;
        if (p.baseInstanceLocation >= 0)
            d.m_gl.ProgramUniform1i(p.program, p.baseInstanceLocation, GLint(firstInstance));
        d.m_gl.DrawArraysInstancedBaseInstance(p.topology, GLint(firstVertex), GLsizei(vertexCount),
                                               GLsizei(instanceCount), firstInstance);
    });
}

void GlCommandList::drawIndexed(uint32_t indexCount, uint32_t instanceCount, uint32_t firstIndex,
                                int32_t vertexOffset, uint32_t firstInstance) {
    if (!checkGraphicsDraw("drawIndexed")) return;
    if (!m_indexBound) {
        error("drawIndexed: no index buffer is bound");
        return;
    }
    if (indexCount == 0 || instanceCount == 0) return;
    m_commands.push_back([=](GlDevice& d) {
        if (!d.prepareDraw()) return;
        const PipelineObj& p = *d.m_rs.pipeline;
        const uint64_t indexSize = d.m_rs.indexType == GL_UNSIGNED_SHORT ? 2 : 4;
        const uintptr_t byteOffset = uintptr_t(d.m_rs.indexOffset + uint64_t(firstIndex) * indexSize);
        if (p.baseInstanceLocation >= 0)
            d.m_gl.ProgramUniform1i(p.program, p.baseInstanceLocation, GLint(firstInstance));
        d.m_gl.DrawElementsInstancedBaseVertexBaseInstance(
            p.topology, GLsizei(indexCount), d.m_rs.indexType, reinterpret_cast<const void*>(byteOffset),
            GLsizei(instanceCount), vertexOffset, firstInstance);
    });
}

void GlCommandList::drawIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) {
    if (!checkGraphicsDraw("drawIndirect")) return;
    GLuint name = 0;
    // VkDrawIndirectCommand and GL's DrawArraysIndirectCommand share one 16-byte layout.
    if (!checkIndirectBuffer(args, offset, uint64_t(drawCount) * 16, "drawIndirect", name)) return;
    if (drawCount == 0) return;
    m_commands.push_back([name, offset, drawCount](GlDevice& d) {
        if (!d.prepareDraw()) return;
        const PipelineObj& p = *d.m_rs.pipeline;
        if (p.baseInstanceLocation >= 0) d.m_gl.ProgramUniform1i(p.program, p.baseInstanceLocation, 0);
        d.m_gl.BindBuffer(GL_DRAW_INDIRECT_BUFFER, name);
        d.m_gl.MultiDrawArraysIndirect(p.topology, reinterpret_cast<const void*>(uintptr_t(offset)),
                                       GLsizei(drawCount), 0);
        d.m_gl.BindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
    });
}

void GlCommandList::drawIndexedIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) {
    if (!checkGraphicsDraw("drawIndexedIndirect")) return;
    if (!m_indexBound) {
        error("drawIndexedIndirect: no index buffer is bound");
        return;
    }
    GLuint name = 0;
    // VkDrawIndexedIndirectCommand and GL's DrawElementsIndirectCommand share one 20-byte layout.
    if (!checkIndirectBuffer(args, offset, uint64_t(drawCount) * 20, "drawIndexedIndirect", name)) return;
    if (drawCount == 0) return;
    m_commands.push_back([name, offset, drawCount](GlDevice& d) {
        if (d.m_rs.indexOffset != 0) {
            d.error("drawIndexedIndirect: the index buffer must be bound at offset 0");
            return;
        }
        if (!d.prepareDraw()) return;
        const PipelineObj& p = *d.m_rs.pipeline;
        if (p.baseInstanceLocation >= 0) d.m_gl.ProgramUniform1i(p.program, p.baseInstanceLocation, 0);
        d.m_gl.BindBuffer(GL_DRAW_INDIRECT_BUFFER, name);
        d.m_gl.MultiDrawElementsIndirect(p.topology, d.m_rs.indexType,
                                         reinterpret_cast<const void*>(uintptr_t(offset)), GLsizei(drawCount),
                                         0);
        d.m_gl.BindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
    });
}

void GlCommandList::resetQueries(QueryPoolHandle pool, uint32_t first, uint32_t count) {
    auto* p = m_device.m_queryPools.get(pool);
    if (!p) {
        error("resetQueries: invalid or destroyed query pool handle");
        return;
    }
    if (first >= (*p)->queries.size() || count > (*p)->queries.size() - first)
        error("resetQueries " + quoted((*p)->debugName) + ": range [" + std::to_string(first) + ", +" +
              std::to_string(count) + ") is out of range");
    // GL query objects are simply overwritten by the next glQueryCounter.
}

void GlCommandList::writeTimestamp(QueryPoolHandle pool, uint32_t index) {
    auto* p = m_device.m_queryPools.get(pool);
    if (!p) {
        error("writeTimestamp: invalid or destroyed query pool handle");
        return;
    }
    if (index >= (*p)->queries.size()) {
        error("writeTimestamp " + quoted((*p)->debugName) + ": slot " + std::to_string(index) +
              " is out of range");
        return;
    }
    m_commands.push_back([obj = *p, index](GlDevice& d) {
        if (d.m_flushTimestamps) d.m_gl.Flush();
        d.m_gl.QueryCounter(obj->queries[index], GL_TIMESTAMP);
        if (d.m_flushTimestamps) d.m_gl.Flush();
        obj->written[index] = 1;
    });
}

void GlCommandList::pushDebugGroup(std::string_view name) {
    ++m_debugDepth;
    m_commands.push_back([text = std::string(name)](GlDevice& d) {
        d.m_gl.PushDebugGroup(GL_DEBUG_SOURCE_APPLICATION, 0, GLsizei(text.size()), text.data());
        ++d.m_rs.debugDepth;
    });
}

void GlCommandList::popDebugGroup() {
    if (m_debugDepth == 0) {
        error("popDebugGroup: no debug group is open");
        return;
    }
    --m_debugDepth;
    m_commands.push_back([](GlDevice& d) {
        if (d.m_rs.debugDepth == 0) return;
        d.m_gl.PopDebugGroup();
        --d.m_rs.debugDepth;
    });
}

// ---------------------------------------------------------------------------------------------
// Replay
// ---------------------------------------------------------------------------------------------
void GlDevice::flushBarriers() {
    if (m_pendingBarriers == 0) return;
    m_gl.MemoryBarrier(m_pendingBarriers);
    m_pendingBarriers = 0;
}

void GlDevice::applyPipelineState(const PipelineObj& p) {
    if (p.depthTest) {
        m_gl.Enable(GL_DEPTH_TEST);
        m_gl.DepthFunc(p.depthFunc);
    } else {
        m_gl.Disable(GL_DEPTH_TEST);
    }
    m_gl.DepthMask(p.depthWrite && !(m_rs.inPass && m_rs.passDepthReadOnly) ? GL_TRUE : GL_FALSE);
    if (p.cullMode == CullMode::None) {
        m_gl.Disable(GL_CULL_FACE);
    } else {
        m_gl.Enable(GL_CULL_FACE);
        m_gl.CullFace(p.cullMode == CullMode::Front ? GL_FRONT : GL_BACK);
    }
    m_gl.FrontFace(p.frontFace);
    const GLuint targets = GLuint(m_info.limits.maxColorTargets);
    for (GLuint i = 0; i < targets; ++i) {
        const BlendState* b = i < p.blend.size() ? &p.blend[i] : nullptr;
        if (b && b->enable) {
            m_gl.Enablei(GL_BLEND, i);
            m_gl.BlendFuncSeparatei(i, blendFactor(b->srcColor), blendFactor(b->dstColor),
                                    blendFactor(b->srcAlpha), blendFactor(b->dstAlpha));
            m_gl.BlendEquationSeparatei(i, blendOp(b->colorOp), blendOp(b->alphaOp));
        } else {
            m_gl.Disablei(GL_BLEND, i);
        }
    }
}

void GlDevice::execBindPipeline(const std::shared_ptr<PipelineObj>& p) {
    m_rs.pipeline = p;
    m_gl.UseProgram(p->program);
    if (p->graphics) {
        m_gl.BindVertexArray(p->vao);
        applyPipelineState(*p);
        m_rs.vertexDirty = true;
        m_rs.indexDirty = true;
    }
    m_rs.bindingsDirty = true;
}

void GlDevice::applyBindings() {
    if (!m_rs.bindingsDirty || !m_rs.pipeline) return;
    m_rs.bindingsDirty = false;
    const PipelineObj& p = *m_rs.pipeline;
    for (uint32_t set = 0; set < kMaxBindGroups; ++set) {
        const BindGroupObj* g = m_rs.groups[set].get();
        if (!g) continue;
        for (const GroupBind& b : g->binds) {
            const BindingSlot* slot = p.findSlot(set, b.binding);
            if (!slot || slot->type != b.type || b.arrayElement >= slot->count) continue;
            const GLuint unit = slot->glBinding + b.arrayElement;
            switch (b.type) {
                case BindingType::UniformBuffer:
                    m_gl.BindBufferRange(GL_UNIFORM_BUFFER, unit, b.object, b.offset, b.size);
                    break;
                case BindingType::StorageBuffer:
                case BindingType::ReadOnlyStorageBuffer:
                    m_gl.BindBufferRange(GL_SHADER_STORAGE_BUFFER, unit, b.object, b.offset, b.size);
                    break;
                case BindingType::SampledTexture:
                    m_gl.BindTextureUnit(unit, b.object);
                    m_gl.BindSampler(unit, b.sampler);
                    break;
                case BindingType::StorageTexture:
                    m_gl.BindImageTexture(unit, b.object, b.mip, b.layered, 0,
                                          slot->writes ? GL_READ_WRITE : GL_READ_ONLY, b.imageFormat);
                    break;
            }
        }
    }
}

bool GlDevice::prepareDraw() {
    if (!m_rs.inPass || !m_rs.passValid) return false;  // the pass failed to begin (already reported)
    if (!m_rs.pipeline || !m_rs.pipeline->graphics) return false;
    const PipelineObj& p = *m_rs.pipeline;
    flushBarriers();
    applyBindings();
    if (m_rs.vertexDirty) {
        m_rs.vertexDirty = false;
        for (size_t slot = 0; slot < p.vertexBuffers.size(); ++slot) {
            const VertexBinding& vb = m_rs.vertexBuffers[slot];
            m_gl.VertexArrayVertexBuffer(p.vao, GLuint(slot), vb.buffer, vb.offset,
                                         GLsizei(p.vertexBuffers[slot].stride));
        }
    }
    if (m_rs.indexDirty) {
        m_rs.indexDirty = false;
        m_gl.VertexArrayElementBuffer(p.vao, m_rs.indexBuffer);
    }
    return true;
}

GLuint GlDevice::framebufferFor(const RenderPassRecord& pass) {
    std::vector<uint32_t> key;
    key.reserve((pass.colors.size() + 1) * 3);
    for (const AttachmentRef& c : pass.colors) key.insert(key.end(), {c.texture, c.mip, c.layer});
    if (pass.hasDepth) key.insert(key.end(), {0xffffffffu, pass.depth.texture, pass.depth.layer});
    if (auto it = m_framebuffers.find(key); it != m_framebuffers.end()) return it->second;

    GLuint fbo = 0;
    m_gl.CreateFramebuffers(1, &fbo);
    auto attach = [&](GLenum point, const AttachmentRef& a) {
        if (a.layered)
            m_gl.NamedFramebufferTextureLayer(fbo, point, a.texture, GLint(a.mip), GLint(a.layer));
        else
            m_gl.NamedFramebufferTexture(fbo, point, a.texture, GLint(a.mip));
    };
    std::vector<GLenum> drawBuffers;
    for (size_t i = 0; i < pass.colors.size(); ++i) {
        attach(GLenum(GL_COLOR_ATTACHMENT0 + i), pass.colors[i]);
        drawBuffers.push_back(GLenum(GL_COLOR_ATTACHMENT0 + i));
    }
    if (pass.hasDepth) attach(GL_DEPTH_ATTACHMENT, pass.depth);
    if (drawBuffers.empty()) {
        const GLenum none = GL_NONE;
        m_gl.NamedFramebufferDrawBuffers(fbo, 1, &none);
    } else {
        m_gl.NamedFramebufferDrawBuffers(fbo, GLsizei(drawBuffers.size()), drawBuffers.data());
    }
    m_gl.NamedFramebufferReadBuffer(fbo, GL_NONE);
    const GLenum status = m_gl.CheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        const char* why = status == GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT           ? "incomplete attachment"
                          : status == GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT ? "missing attachment"
                          : status == GL_FRAMEBUFFER_UNSUPPORTED ? "unsupported format combination"
                          : status == GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS ? "incomplete layer targets"
                                                                              : "incomplete";
        char code[16];
        std::snprintf(code, sizeof code, "0x%04x", status);
        error("render pass " + quoted(pass.debugName) + ": framebuffer is not complete (" + why + ", " +
              code + ")");
        m_gl.DeleteFramebuffers(1, &fbo);
        return 0;
    }
    if (!pass.debugName.empty()) label(GL_FRAMEBUFFER, fbo, pass.debugName);
    m_framebuffers.emplace(std::move(key), fbo);
    return fbo;
}

void GlDevice::purgeFramebuffers(GLuint texture) {
    for (auto it = m_framebuffers.begin(); it != m_framebuffers.end();) {
        const std::vector<uint32_t>& key = it->first;
        bool uses = false;
        // Colour triplets are (texture, mip, layer); the depth triplet is (~0, texture, layer).
        for (size_t i = 0; i + 2 < key.size() && !uses; i += 3)
            uses = key[i] == 0xffffffffu ? key[i + 1] == texture : key[i] == texture;
        if (uses) {
            m_gl.DeleteFramebuffers(1, &it->second);
            it = m_framebuffers.erase(it);
        } else {
            ++it;
        }
    }
}

void GlDevice::execBeginRenderPass(const RenderPassRecord& pass) {
    m_rs.inPass = true;
    m_rs.passValid = false;
    m_rs.passDepthReadOnly = pass.hasDepth && pass.depthReadOnly;
    const GLuint fbo = framebufferFor(pass);
    if (!fbo) return;
    m_rs.passValid = true;
    m_rs.passFbo = fbo;
    m_rs.pass = pass;
    if (!pass.debugName.empty())
        m_gl.PushDebugGroup(GL_DEBUG_SOURCE_APPLICATION, 0, GLsizei(pass.debugName.size()),
                            pass.debugName.data());

    flushBarriers();
    m_gl.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    // Full-target viewport and scissor until the pass sets its own.
    m_gl.ViewportIndexedf(0, 0.0f, 0.0f, float(pass.width), float(pass.height));
    m_gl.DepthRangeIndexed(0, 0.0, 1.0);
    m_gl.ScissorIndexed(0, 0, 0, GLsizei(pass.width), GLsizei(pass.height));

    // Clears obey the write masks: open them, then restore the bound pipeline's.
    std::vector<GLenum> discard;
    for (size_t i = 0; i < pass.colors.size(); ++i) {
        const AttachmentRef& c = pass.colors[i];
        if (c.load == LoadOp::Clear) {
            m_gl.ColorMaski(GLuint(i), GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
            if (formatInfo(c.format).isInteger) {
                const GLuint v[4] = {
                    GLuint(std::max(0.0f, c.clearColor[0])), GLuint(std::max(0.0f, c.clearColor[1])),
                    GLuint(std::max(0.0f, c.clearColor[2])), GLuint(std::max(0.0f, c.clearColor[3]))};
                m_gl.ClearNamedFramebufferuiv(fbo, GL_COLOR, GLint(i), v);
            } else {
                m_gl.ClearNamedFramebufferfv(fbo, GL_COLOR, GLint(i), c.clearColor.data());
            }
        } else if (c.load == LoadOp::DontCare) {
            discard.push_back(GLenum(GL_COLOR_ATTACHMENT0 + i));
        }
    }
    if (pass.hasDepth) {
        if (pass.depth.load == LoadOp::Clear) {
            m_gl.DepthMask(GL_TRUE);
            m_gl.ClearNamedFramebufferfv(fbo, GL_DEPTH, 0, &pass.clearDepth);
        } else if (pass.depth.load == LoadOp::DontCare) {
            discard.push_back(GL_DEPTH_ATTACHMENT);
        }
    }
    if (!discard.empty()) m_gl.InvalidateNamedFramebufferData(fbo, GLsizei(discard.size()), discard.data());
    const bool pipelineWritesDepth = m_rs.pipeline && m_rs.pipeline->graphics && m_rs.pipeline->depthWrite;
    m_gl.DepthMask(pipelineWritesDepth && !m_rs.passDepthReadOnly ? GL_TRUE : GL_FALSE);
}

void GlDevice::execEndRenderPass() {
    if (m_rs.inPass && m_rs.passValid) {
        std::vector<GLenum> discard;
        for (size_t i = 0; i < m_rs.pass.colors.size(); ++i)
            if (m_rs.pass.colors[i].store == StoreOp::DontCare)
                discard.push_back(GLenum(GL_COLOR_ATTACHMENT0 + i));
        if (m_rs.pass.hasDepth && m_rs.pass.depth.store == StoreOp::DontCare)
            discard.push_back(GL_DEPTH_ATTACHMENT);
        if (!discard.empty())
            m_gl.InvalidateNamedFramebufferData(m_rs.passFbo, GLsizei(discard.size()), discard.data());
        if (!m_rs.pass.debugName.empty()) m_gl.PopDebugGroup();
    }
    m_rs.inPass = false;
    m_rs.passValid = false;
    m_rs.passDepthReadOnly = false;
    m_rs.passFbo = 0;
    m_rs.pass = RenderPassRecord{};
}

}  // namespace rhi::gl
