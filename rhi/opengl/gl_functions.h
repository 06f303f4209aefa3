// OpenGL 4.5 core entry points used by the GL backend, loaded at run time through the context's
// get-proc-address function (eglGetProcAddress / OSMesaGetProcAddress / glfwGetProcAddress).
// The backend never links libGL or libOpenGL: every call goes through this table, so the same
// code runs on an EGL, an OSMesa or a GLFW context. Types and enums come from <GL/glcorearb.h>.
#pragma once

#include <GL/glcorearb.h>

#include <string>
#include <vector>

namespace rhi::gl {

// X(PFN type, name without the "gl" prefix)
#define PENUMBRA_GL_FUNCTIONS(X)                                                                         \
    /* state and queries */                                                                              \
    X(PFNGLGETSTRINGPROC, GetString)                                                                     \
    X(PFNGLGETINTEGERVPROC, GetIntegerv)                                                                 \
    X(PFNGLGETINTEGER64VPROC, GetInteger64v)                                                             \
    X(PFNGLGETINTEGERI_VPROC, GetIntegeri_v)                                                             \
    X(PFNGLGETERRORPROC, GetError)                                                                       \
    X(PFNGLENABLEPROC, Enable)                                                                           \
    X(PFNGLDISABLEPROC, Disable)                                                                         \
    X(PFNGLENABLEIPROC, Enablei)                                                                         \
    X(PFNGLDISABLEIPROC, Disablei)                                                                       \
    X(PFNGLCLIPCONTROLPROC, ClipControl)                                                                 \
    X(PFNGLPIXELSTOREIPROC, PixelStorei)                                                                 \
    X(PFNGLFINISHPROC, Finish)                                                                           \
    X(PFNGLGETGRAPHICSRESETSTATUSPROC, GetGraphicsResetStatus)                                           \
    X(PFNGLFLUSHPROC, Flush)                                                                             \
    /* debug output */                                                                                   \
    X(PFNGLDEBUGMESSAGECALLBACKPROC, DebugMessageCallback)                                               \
    X(PFNGLDEBUGMESSAGECONTROLPROC, DebugMessageControl)                                                 \
    X(PFNGLOBJECTLABELPROC, ObjectLabel)                                                                 \
    X(PFNGLPUSHDEBUGGROUPPROC, PushDebugGroup)                                                           \
    X(PFNGLPOPDEBUGGROUPPROC, PopDebugGroup)                                                             \
    /* buffers */                                                                                        \
    X(PFNGLCREATEBUFFERSPROC, CreateBuffers)                                                             \
    X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                                                             \
    X(PFNGLNAMEDBUFFERSTORAGEPROC, NamedBufferStorage)                                                   \
    X(PFNGLNAMEDBUFFERSUBDATAPROC, NamedBufferSubData)                                                   \
    X(PFNGLGETNAMEDBUFFERSUBDATAPROC, GetNamedBufferSubData)                                             \
    X(PFNGLMAPNAMEDBUFFERRANGEPROC, MapNamedBufferRange)                                                 \
    X(PFNGLCOPYNAMEDBUFFERSUBDATAPROC, CopyNamedBufferSubData)                                           \
    X(PFNGLCLEARNAMEDBUFFERSUBDATAPROC, ClearNamedBufferSubData)                                         \
    X(PFNGLBINDBUFFERPROC, BindBuffer)                                                                   \
    X(PFNGLBINDBUFFERBASEPROC, BindBufferBase)                                                           \
    X(PFNGLBINDBUFFERRANGEPROC, BindBufferRange)                                                         \
    /* textures and samplers */                                                                          \
    X(PFNGLCREATETEXTURESPROC, CreateTextures)                                                           \
    X(PFNGLDELETETEXTURESPROC, DeleteTextures)                                                           \
    X(PFNGLTEXTURESTORAGE2DPROC, TextureStorage2D)                                                       \
    X(PFNGLTEXTURESTORAGE3DPROC, TextureStorage3D)                                                       \
    X(PFNGLTEXTURESUBIMAGE2DPROC, TextureSubImage2D)                                                     \
    X(PFNGLTEXTURESUBIMAGE3DPROC, TextureSubImage3D)                                                     \
    X(PFNGLGETTEXTURESUBIMAGEPROC, GetTextureSubImage)                                                   \
    X(PFNGLBINDTEXTUREUNITPROC, BindTextureUnit)                                                         \
    X(PFNGLBINDIMAGETEXTUREPROC, BindImageTexture)                                                       \
    X(PFNGLCREATESAMPLERSPROC, CreateSamplers)                                                           \
    X(PFNGLDELETESAMPLERSPROC, DeleteSamplers)                                                           \
    X(PFNGLSAMPLERPARAMETERIPROC, SamplerParameteri)                                                     \
    X(PFNGLSAMPLERPARAMETERFPROC, SamplerParameterf)                                                     \
    X(PFNGLBINDSAMPLERPROC, BindSampler)                                                                 \
    /* shaders and programs */                                                                           \
    X(PFNGLCREATESHADERPROC, CreateShader)                                                               \
    X(PFNGLDELETESHADERPROC, DeleteShader)                                                               \
    X(PFNGLSHADERSOURCEPROC, ShaderSource)                                                               \
    X(PFNGLCOMPILESHADERPROC, CompileShader)                                                             \
    X(PFNGLGETSHADERIVPROC, GetShaderiv)                                                                 \
    X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                                                       \
    X(PFNGLCREATEPROGRAMPROC, CreateProgram)                                                             \
    X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                                                             \
    X(PFNGLATTACHSHADERPROC, AttachShader)                                                               \
    X(PFNGLDETACHSHADERPROC, DetachShader)                                                               \
    X(PFNGLLINKPROGRAMPROC, LinkProgram)                                                                 \
    X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                                                               \
    X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                                                     \
    X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                                                   \
    X(PFNGLPROGRAMUNIFORM1IPROC, ProgramUniform1i)                                                       \
    X(PFNGLUSEPROGRAMPROC, UseProgram)                                                                   \
    /* vertex arrays */                                                                                  \
    X(PFNGLCREATEVERTEXARRAYSPROC, CreateVertexArrays)                                                   \
    X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                                                   \
    X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                                                         \
    X(PFNGLENABLEVERTEXARRAYATTRIBPROC, EnableVertexArrayAttrib)                                         \
    X(PFNGLVERTEXARRAYATTRIBFORMATPROC, VertexArrayAttribFormat)                                         \
    X(PFNGLVERTEXARRAYATTRIBIFORMATPROC, VertexArrayAttribIFormat)                                       \
    X(PFNGLVERTEXARRAYATTRIBBINDINGPROC, VertexArrayAttribBinding)                                       \
    X(PFNGLVERTEXARRAYBINDINGDIVISORPROC, VertexArrayBindingDivisor)                                     \
    X(PFNGLVERTEXARRAYVERTEXBUFFERPROC, VertexArrayVertexBuffer)                                         \
    X(PFNGLVERTEXARRAYELEMENTBUFFERPROC, VertexArrayElementBuffer)                                       \
    /* framebuffers */                                                                                   \
    X(PFNGLCREATEFRAMEBUFFERSPROC, CreateFramebuffers)                                                   \
    X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                                                   \
    X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                                                         \
    X(PFNGLNAMEDFRAMEBUFFERTEXTUREPROC, NamedFramebufferTexture)                                         \
    X(PFNGLNAMEDFRAMEBUFFERTEXTURELAYERPROC, NamedFramebufferTextureLayer)                               \
    X(PFNGLNAMEDFRAMEBUFFERDRAWBUFFERSPROC, NamedFramebufferDrawBuffers)                                 \
    X(PFNGLNAMEDFRAMEBUFFERREADBUFFERPROC, NamedFramebufferReadBuffer)                                   \
    X(PFNGLCHECKNAMEDFRAMEBUFFERSTATUSPROC, CheckNamedFramebufferStatus)                                 \
    X(PFNGLCLEARNAMEDFRAMEBUFFERFVPROC, ClearNamedFramebufferfv)                                         \
    X(PFNGLCLEARNAMEDFRAMEBUFFERUIVPROC, ClearNamedFramebufferuiv)                                       \
    X(PFNGLINVALIDATENAMEDFRAMEBUFFERDATAPROC, InvalidateNamedFramebufferData)                           \
    X(PFNGLBLITNAMEDFRAMEBUFFERPROC, BlitNamedFramebuffer)                                               \
    /* fixed-function state */                                                                           \
    X(PFNGLVIEWPORTINDEXEDFPROC, ViewportIndexedf)                                                       \
    X(PFNGLDEPTHRANGEINDEXEDPROC, DepthRangeIndexed)                                                     \
    X(PFNGLSCISSORINDEXEDPROC, ScissorIndexed)                                                           \
    X(PFNGLDEPTHFUNCPROC, DepthFunc)                                                                     \
    X(PFNGLDEPTHMASKPROC, DepthMask)                                                                     \
    X(PFNGLCOLORMASKIPROC, ColorMaski)                                                                   \
    X(PFNGLCULLFACEPROC, CullFace)                                                                       \
    X(PFNGLFRONTFACEPROC, FrontFace)                                                                     \
    X(PFNGLBLENDFUNCSEPARATEIPROC, BlendFuncSeparatei)                                                   \
    X(PFNGLBLENDEQUATIONSEPARATEIPROC, BlendEquationSeparatei)                                           \
    /* work */                                                                                           \
    X(PFNGLDISPATCHCOMPUTEPROC, DispatchCompute)                                                         \
    X(PFNGLDISPATCHCOMPUTEINDIRECTPROC, DispatchComputeIndirect)                                         \
    X(PFNGLDRAWARRAYSINSTANCEDBASEINSTANCEPROC, DrawArraysInstancedBaseInstance)                         \
    X(PFNGLDRAWELEMENTSINSTANCEDBASEVERTEXBASEINSTANCEPROC, DrawElementsInstancedBaseVertexBaseInstance) \
    X(PFNGLMULTIDRAWARRAYSINDIRECTPROC, MultiDrawArraysIndirect)                                         \
    X(PFNGLMULTIDRAWELEMENTSINDIRECTPROC, MultiDrawElementsIndirect)                                     \
    /* copies, views and capabilities */                                                                 \
    X(PFNGLCOPYIMAGESUBDATAPROC, CopyImageSubData)                                                       \
    X(PFNGLGENTEXTURESPROC, GenTextures)                                                                 \
    X(PFNGLTEXTUREVIEWPROC, TextureView)                                                                 \
    X(PFNGLGETINTERNALFORMATIVPROC, GetInternalformativ)                                                 \
    X(PFNGLGETSTRINGIPROC, GetStringi)                                                                   \
    /* synchronisation and queries */                                                                    \
    X(PFNGLMEMORYBARRIERPROC, MemoryBarrier)                                                             \
    X(PFNGLFENCESYNCPROC, FenceSync)                                                                     \
    X(PFNGLCLIENTWAITSYNCPROC, ClientWaitSync)                                                           \
    X(PFNGLDELETESYNCPROC, DeleteSync)                                                                   \
    X(PFNGLCREATEQUERIESPROC, CreateQueries)                                                             \
    X(PFNGLDELETEQUERIESPROC, DeleteQueries)                                                             \
    X(PFNGLQUERYCOUNTERPROC, QueryCounter)                                                               \
    X(PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v)

struct Functions {
#define PENUMBRA_GL_DECLARE(type, name) type name = nullptr;
    PENUMBRA_GL_FUNCTIONS(PENUMBRA_GL_DECLARE)
#undef PENUMBRA_GL_DECLARE

    using GenericProc = void (*)();
    using ProcLoader = GenericProc (*)(const char* name, void* user);
    // Loads every entry point; returns the names that could not be resolved (empty = success).
    std::vector<std::string> load(ProcLoader loader, void* user);
};

}  // namespace rhi::gl
