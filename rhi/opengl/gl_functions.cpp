#include "rhi/opengl/gl_functions.h"

namespace rhi::gl {

std::vector<std::string> Functions::load(ProcLoader loader, void* user) {
    std::vector<std::string> missing;
#define PENUMBRA_GL_LOAD(type, name)                         \
    name = reinterpret_cast<type>(loader("gl" #name, user)); \
    if (!name) missing.emplace_back("gl" #name);
    PENUMBRA_GL_FUNCTIONS(PENUMBRA_GL_LOAD)
#undef PENUMBRA_GL_LOAD
    return missing;
}

}  // namespace rhi::gl
