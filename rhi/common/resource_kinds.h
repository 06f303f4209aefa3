// Internal: the seven kinds of RHI object as one X-macro list, so that the per-kind overloads of
// Device (destroy, isAlive) are written once per backend instead of seven times:
//   X(handle type, the backend's pool member, name used in messages)
#pragma once

#define RHI_RESOURCE_KINDS(X)                      \
    X(BufferHandle, m_buffers, "buffer")           \
    X(TextureHandle, m_textures, "texture")        \
    X(SamplerHandle, m_samplers, "sampler")        \
    X(ShaderHandle, m_shaders, "shader")           \
    X(PipelineHandle, m_pipelines, "pipeline")     \
    X(BindGroupHandle, m_bindGroups, "bind group") \
    X(QueryPoolHandle, m_queryPools, "query pool")
