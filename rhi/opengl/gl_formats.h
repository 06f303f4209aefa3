// Translation of rhi enums to OpenGL enums.
#pragma once

#include <GL/glcorearb.h>

#include "rhi/types.h"

namespace rhi::gl {

struct TextureFormatGl {
    GLenum internalFormat = 0;  // 0 = not usable as a texture
    GLenum pixelFormat = 0;     // client format for glTextureSubImage / glGetTextureSubImage
    GLenum pixelType = 0;
    GLenum imageFormat = 0;  // glBindImageTexture format, 0 = not usable as a storage image
};
TextureFormatGl textureFormat(Format f);

struct VertexFormatGl {
    GLint components = 0;  // 0 = not usable as a vertex attribute
    GLenum type = 0;
    GLboolean normalized = GL_FALSE;
    bool integer = false;  // glVertexArrayAttribIFormat
};
VertexFormatGl vertexFormat(Format f);

GLenum textureTarget(TextureDimension d);
GLenum topology(PrimitiveTopology t);
GLenum compareOp(CompareOp op);
GLenum blendFactor(BlendFactor f);
GLenum blendOp(BlendOp op);
GLenum addressMode(AddressMode m);
GLenum minFilter(Filter min, Filter mip);
GLenum magFilter(Filter mag);

}  // namespace rhi::gl
