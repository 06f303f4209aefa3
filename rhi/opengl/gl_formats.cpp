#include "rhi/opengl/gl_formats.h"

namespace rhi::gl {

TextureFormatGl textureFormat(Format f) {
    switch (f) {
        case Format::R8_UNORM:
            return {GL_R8, GL_RED, GL_UNSIGNED_BYTE, GL_R8};
        case Format::R8_UINT:
            return {GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, GL_R8UI};
        case Format::R16_FLOAT:
            return {GL_R16F, GL_RED, GL_HALF_FLOAT, GL_R16F};
        case Format::R32_FLOAT:
            return {GL_R32F, GL_RED, GL_FLOAT, GL_R32F};
        case Format::R32_UINT:
            return {GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, GL_R32UI};
        case Format::RG16_FLOAT:
            return {GL_RG16F, GL_RG, GL_HALF_FLOAT, GL_RG16F};
        case Format::RG32_FLOAT:
            return {GL_RG32F, GL_RG, GL_FLOAT, GL_RG32F};
        case Format::RGBA8_UNORM:
            return {GL_RGBA8, GL_RGBA, GL_UNSIGNED_BYTE, GL_RGBA8};
        // sRGB formats cannot be bound as images in GL (nor, portably, in Vulkan).
        case Format::RGBA8_SRGB:
            return {GL_SRGB8_ALPHA8, GL_RGBA, GL_UNSIGNED_BYTE, 0};
        case Format::RGBA16_FLOAT:
            return {GL_RGBA16F, GL_RGBA, GL_HALF_FLOAT, GL_RGBA16F};
        case Format::RGBA32_FLOAT:
            return {GL_RGBA32F, GL_RGBA, GL_FLOAT, GL_RGBA32F};
        case Format::D32_FLOAT:
            return {GL_DEPTH_COMPONENT32F, GL_DEPTH_COMPONENT, GL_FLOAT, 0};
        case Format::RGB32_FLOAT:
        case Format::Undefined:
        case Format::Count:
            break;
    }
    return {};
}

VertexFormatGl vertexFormat(Format f) {
    switch (f) {
        case Format::R8_UNORM:
            return {1, GL_UNSIGNED_BYTE, GL_TRUE, false};
        case Format::R8_UINT:
            return {1, GL_UNSIGNED_BYTE, GL_FALSE, true};
        case Format::R16_FLOAT:
            return {1, GL_HALF_FLOAT, GL_FALSE, false};
        case Format::R32_FLOAT:
            return {1, GL_FLOAT, GL_FALSE, false};
        case Format::R32_UINT:
            return {1, GL_UNSIGNED_INT, GL_FALSE, true};
        case Format::RG16_FLOAT:
            return {2, GL_HALF_FLOAT, GL_FALSE, false};
        case Format::RG32_FLOAT:
            return {2, GL_FLOAT, GL_FALSE, false};
        case Format::RGBA8_UNORM:
            return {4, GL_UNSIGNED_BYTE, GL_TRUE, false};
        case Format::RGBA16_FLOAT:
            return {4, GL_HALF_FLOAT, GL_FALSE, false};
        case Format::RGBA32_FLOAT:
            return {4, GL_FLOAT, GL_FALSE, false};
        case Format::RGB32_FLOAT:
            return {3, GL_FLOAT, GL_FALSE, false};
        case Format::RGBA8_SRGB:
        case Format::D32_FLOAT:
        case Format::Undefined:
        case Format::Count:
            break;
    }
    return {};
}

GLenum textureTarget(TextureDimension d) {
    switch (d) {
        case TextureDimension::Tex2D:
            return GL_TEXTURE_2D;
        case TextureDimension::Tex2DArray:
            return GL_TEXTURE_2D_ARRAY;
        case TextureDimension::Tex3D:
            return GL_TEXTURE_3D;
    }
    return GL_TEXTURE_2D;
}

GLenum topology(PrimitiveTopology t) {
    switch (t) {
        case PrimitiveTopology::TriangleList:
            return GL_TRIANGLES;
        case PrimitiveTopology::TriangleStrip:
            return GL_TRIANGLE_STRIP;
        case PrimitiveTopology::LineList:
            return GL_LINES;
        case PrimitiveTopology::PointList:
            return GL_POINTS;
    }
    return GL_TRIANGLES;
}

GLenum compareOp(CompareOp op) {
    switch (op) {
        case CompareOp::Never:
            return GL_NEVER;
        case CompareOp::Less:
            return GL_LESS;
        case CompareOp::LessEqual:
            return GL_LEQUAL;
        case CompareOp::Greater:
            return GL_GREATER;
        case CompareOp::GreaterEqual:
            return GL_GEQUAL;
        case CompareOp::Equal:
            return GL_EQUAL;
        case CompareOp::NotEqual:
            return GL_NOTEQUAL;
        case CompareOp::Always:
            return GL_ALWAYS;
    }
    return GL_LESS;
}

GLenum blendFactor(BlendFactor f) {
    switch (f) {
        case BlendFactor::Zero:
            return GL_ZERO;
        case BlendFactor::One:
            return GL_ONE;
        case BlendFactor::SrcColor:
            return GL_SRC_COLOR;
        case BlendFactor::OneMinusSrcColor:
            return GL_ONE_MINUS_SRC_COLOR;
        case BlendFactor::SrcAlpha:
            return GL_SRC_ALPHA;
        case BlendFactor::OneMinusSrcAlpha:
            return GL_ONE_MINUS_SRC_ALPHA;
        case BlendFactor::DstColor:
            return GL_DST_COLOR;
        case BlendFactor::OneMinusDstColor:
            return GL_ONE_MINUS_DST_COLOR;
        case BlendFactor::DstAlpha:
            return GL_DST_ALPHA;
        case BlendFactor::OneMinusDstAlpha:
            return GL_ONE_MINUS_DST_ALPHA;
    }
    return GL_ONE;
}

GLenum blendOp(BlendOp op) {
    switch (op) {
        case BlendOp::Add:
            return GL_FUNC_ADD;
        case BlendOp::Subtract:
            return GL_FUNC_SUBTRACT;
        case BlendOp::ReverseSubtract:
            return GL_FUNC_REVERSE_SUBTRACT;
        case BlendOp::Min:
            return GL_MIN;
        case BlendOp::Max:
            return GL_MAX;
    }
    return GL_FUNC_ADD;
}

GLenum addressMode(AddressMode m) {
    switch (m) {
        case AddressMode::ClampToEdge:
            return GL_CLAMP_TO_EDGE;
        case AddressMode::Repeat:
            return GL_REPEAT;
        case AddressMode::MirroredRepeat:
            return GL_MIRRORED_REPEAT;
    }
    return GL_CLAMP_TO_EDGE;
}

GLenum minFilter(Filter min, Filter mip) {
    if (min == Filter::Nearest)
        return mip == Filter::Nearest ? GL_NEAREST_MIPMAP_NEAREST : GL_NEAREST_MIPMAP_LINEAR;
    return mip == Filter::Nearest ? GL_LINEAR_MIPMAP_NEAREST : GL_LINEAR_MIPMAP_LINEAR;
}

GLenum magFilter(Filter mag) { return mag == Filter::Nearest ? GL_NEAREST : GL_LINEAR; }

}  // namespace rhi::gl
