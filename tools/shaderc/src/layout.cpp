// Parameter blocks as C++ structs: SPIR-V reflection of uniform, push-constant and storage blocks
// (and the structs inside them) into layouts with explicit offsets, the program-wide merge of
// those layouts, the check of the shared per-view block, and the program's named slots.
#include "internal.h"

#include <spirv_cross/spirv_cross.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <sstream>

namespace fs = std::filesystem;

namespace penumbra::shaderc::detail {
namespace {

// C++ keywords a GLSL identifier may legally be (GLSL itself reserves the others), and the
// namespaces and type names the generated code uses unqualified or as its first qualifier.
bool isCppOnlyKeyword(const std::string& name) {
    static const std::set<std::string> kKeywords = {
        "alignas",       "alignof",     "and",        "and_eq",   "asm",
        "auto",          "bitand",      "bitor",      "catch",    "char",
        "char8_t",       "char16_t",    "char32_t",   "class",    "co_await",
        "co_return",     "co_yield",    "compl",      "concept",  "consteval",
        "constexpr",     "constinit",   "const_cast", "decltype", "delete",
        "dynamic_cast",  "enum",        "explicit",   "export",   "extern",
        "false",         "friend",      "goto",       "inline",   "long",
        "mutable",       "namespace",   "new",        "noexcept", "not",
        "not_eq",        "nullptr",     "operator",   "or",       "or_eq",
        "private",       "protected",   "public",     "register", "reinterpret_cast",
        "requires",      "short",       "signed",     "sizeof",   "static",
        "static_assert", "static_cast", "template",   "this",     "thread_local",
        "throw",         "true",        "try",        "typedef",  "typeid",
        "typename",      "union",       "unsigned",   "using",    "virtual",
        "volatile",      "wchar_t",     "xor",        "xor_eq",   "int8_t",
        "uint8_t",       "int32_t",     "uint32_t",   "offsetof", "glm",
        "std",           "rhi",         "penumbra"};
    return kKeywords.count(name) != 0;
}

// Names the generated header declares in the program's namespace.
bool isReservedGeneratedName(const std::string& name) {
    static const std::set<std::string> kNames = {"Variant", "kVariantCount", "kVariantNames", "PushConstants",
                                                 "slot",    "vertex",        "fragment",      "compute"};
    return kNames.count(name) != 0;
}

std::string stripLineComment(const std::string& line) {
    const size_t pos = line.find("//");
    return pos == std::string::npos ? line : line.substr(0, pos);
}

std::string glslScalarName(spirv_cross::SPIRType::BaseType base) {
    switch (base) {
        case spirv_cross::SPIRType::Float:
            return "float";
        case spirv_cross::SPIRType::Int:
            return "int";
        case spirv_cross::SPIRType::UInt:
            return "uint";
        case spirv_cross::SPIRType::Boolean:
            return "bool";
        case spirv_cross::SPIRType::Double:
            return "double";
        case spirv_cross::SPIRType::Half:
            return "float16_t";
        case spirv_cross::SPIRType::Int64:
            return "int64_t";
        case spirv_cross::SPIRType::UInt64:
            return "uint64_t";
        case spirv_cross::SPIRType::Short:
            return "int16_t";
        case spirv_cross::SPIRType::UShort:
            return "uint16_t";
        case spirv_cross::SPIRType::SByte:
            return "int8_t";
        case spirv_cross::SPIRType::UByte:
            return "uint8_t";
        default:
            return "an opaque or unknown type";
    }
}

std::string glslTypeName(const spirv_cross::SPIRType& t) {
    const std::string scalar = glslScalarName(t.basetype);
    if (t.columns > 1) {
        const std::string c = std::to_string(t.columns);
        const std::string r = std::to_string(t.vecsize);
        return std::string(t.basetype == spirv_cross::SPIRType::Double ? "dmat" : "mat") + c +
               (t.columns == t.vecsize ? "" : "x" + r);
    }
    if (t.vecsize == 1) return scalar;
    std::string prefix;
    switch (t.basetype) {
        case spirv_cross::SPIRType::Float:
            prefix = "";
            break;
        case spirv_cross::SPIRType::Int:
            prefix = "i";
            break;
        case spirv_cross::SPIRType::UInt:
            prefix = "u";
            break;
        case spirv_cross::SPIRType::Boolean:
            prefix = "b";
            break;
        case spirv_cross::SPIRType::Double:
            prefix = "d";
            break;
        default:
            return scalar + std::to_string(t.vecsize);
    }
    return prefix + "vec" + std::to_string(t.vecsize);
}

// Scalar, vector or matrix -> C++ type and size. GLSL bool in a block is 32 bits: uint32_t.
// Column-major matrices whose column stride is 16 bytes (std140, or vec4 columns) map to
// glm::matCx4; with tightly packed columns to glm::matCxR.
bool mapValueType(const spirv_cross::SPIRType& t, uint32_t matrixStride, bool rowMajor, std::string& cpp,
                  uint32_t& size, std::string& why) {
    const bool isFloat = t.basetype == spirv_cross::SPIRType::Float;
    const bool isInt = t.basetype == spirv_cross::SPIRType::Int;
    const bool isUint =
        t.basetype == spirv_cross::SPIRType::UInt || t.basetype == spirv_cross::SPIRType::Boolean;
    if (!isFloat && !isInt && !isUint) {
        why = glslTypeName(t) +
              " has no C++ parameter type (use float, int, uint, bool and their vector and matrix types)";
        return false;
    }
    if (t.vecsize < 1 || t.vecsize > 4) {
        why = "vectors of " + std::to_string(t.vecsize) + " components are not supported";
        return false;
    }
    if (t.columns == 1) {
        if (t.vecsize == 1) {
            cpp = isFloat ? "float" : isInt ? "int32_t" : "uint32_t";
        } else {
            cpp = std::string("::glm::") +
                  (isFloat ? ""
                   : isInt ? "i"
                           : "u") +
                  "vec" + std::to_string(t.vecsize);
        }
        size = 4 * t.vecsize;
        return true;
    }
    if (!isFloat) {
        why = "integer and bool matrices are not supported";
        return false;
    }
    if (rowMajor) {
        why = "row_major matrices are not supported in parameter blocks (use the default column_major)";
        return false;
    }
    const std::string columns = std::to_string(t.columns);
    if (matrixStride == 4 * t.vecsize) {
        cpp = "::glm::mat" + columns + (t.columns == t.vecsize ? "" : "x" + std::to_string(t.vecsize));
    } else if (matrixStride == 16) {
        cpp = "::glm::mat" + columns + (t.columns == 4 ? "" : "x4");  // columns padded to vec4 (std140)
    } else {
        why = glslTypeName(t) + " with a column stride of " + std::to_string(matrixStride) +
              " bytes has no glm equivalent";
        return false;
    }
    size = t.columns * matrixStride;
    return true;
}

class LayoutReflector {
public:
    LayoutReflector(const spirv_cross::Compiler& compiler, StageOutput& stage,
                    std::vector<std::string>& diagnostics)
        : m_compiler(compiler), m_stage(stage), m_diagnostics(diagnostics) {}

    // Reflects `type` (a block or a struct); its nested structs are appended to stage.layouts
    // first. A storage block ending in a runtime-sized array is not a layout (its structs are).
    bool reflect(const spirv_cross::SPIRType& type, BlockKind kind, uint32_t set, uint32_t binding,
                 std::string& name) {
        name = m_compiler.get_name(type.self);
        if (name.empty()) {
            m_diagnostics.push_back(m_stage.path + ": error: a " + describe(kind) +
                                    " has no type name; parameter structs are named after it");
            return false;
        }
        if (kind == BlockKind::Struct && m_done.count(type.self)) return true;
        m_done.insert(type.self);

        StructLayout layout;
        layout.name = name;
        layout.kind = kind;
        layout.set = set;
        layout.binding = binding;
        layout.origin = locateDeclaration(m_stage.files, name, "");
        bool ok = true;
        if (isCppOnlyKeyword(name) || isReservedGeneratedName(name)) {
            error(layout.origin, "'" + name +
                                     "' cannot name a generated C++ struct (a C++ keyword or a name "
                                     "the generated header declares itself); rename the GLSL type");
            ok = false;
        }
        bool runtimeArray = false;
        for (uint32_t i = 0; i < type.member_types.size(); ++i) {
            const spirv_cross::SPIRType& memberType = m_compiler.get_type(type.member_types[i]);
            StructMember m;
            m.name = m_compiler.get_member_name(type.self, i);
            m.offset = m_compiler.type_struct_member_offset(type, i);
            const std::string where = locateDeclaration(m_stage.files, name, m.name);
            m.origin = where;
            if (m.name.empty() || isCppOnlyKeyword(m.name)) {
                error(where,
                      "member '" + m.name + "' of '" + name + "' cannot be a C++ member name; rename it");
                ok = false;
                continue;
            }
            if (memberType.array.size() > 1) {
                error(where, "member '" + m.name + "' of '" + name +
                                 "': arrays of arrays are not supported in parameter blocks");
                ok = false;
                continue;
            }
            if (memberType.array.size() == 1) {
                if (!memberType.array_size_literal[0]) {
                    error(
                        where,
                        "member '" + m.name + "' of '" + name +
                            "': specialization-constant-sized arrays are not supported in parameter blocks");
                    ok = false;
                    continue;
                }
                if (memberType.array[0] == 0) {
                    if (kind != BlockKind::StorageBlock || i + 1 != type.member_types.size()) {
                        error(where, "member '" + m.name + "' of '" + name + "': runtime-sized array");
                        ok = false;
                        continue;
                    }
                    runtimeArray = true;
                    if (memberType.basetype == spirv_cross::SPIRType::Struct) {
                        std::string element;
                        if (!reflect(m_compiler.get_type(memberType.self), BlockKind::Struct, 0, 0,
                                     element)) {
                            ok = false;
                            continue;
                        }
                        // The element struct's C++ size must be the array stride (std::vector<T> uploads).
                        for (StructLayout& l : m_stage.layouts) {
                            if (l.name == element)
                                l.runtimeArrayStride = m_compiler.type_struct_member_array_stride(type, i);
                        }
                    }
                    continue;
                }
                m.arraySize = memberType.array[0];
                m.arrayStride = m_compiler.type_struct_member_array_stride(type, i);
            }
            if (memberType.basetype == spirv_cross::SPIRType::Struct) {
                std::string nested;
                if (!reflect(m_compiler.get_type(memberType.self), BlockKind::Struct, 0, 0, nested)) {
                    ok = false;
                    continue;
                }
                m.isStruct = true;
                m.cppType = nested;
                m.glslType = nested;
            } else {
                const uint32_t matrixStride =
                    memberType.columns > 1 ? m_compiler.type_struct_member_matrix_stride(type, i) : 0;
                const bool rowMajor = m_compiler.has_member_decoration(type.self, i, spv::DecorationRowMajor);
                std::string why;
                m.glslType = glslTypeName(memberType);
                if (!mapValueType(memberType, matrixStride, rowMajor, m.cppType, m.elementSize, why)) {
                    error(where, "member '" + m.name + "' of '" + name + "': " + why);
                    ok = false;
                    continue;
                }
                if (m.arraySize > 0 && m.arrayStride != m.elementSize) {
                    error(where,
                          "member '" + m.name + "' of '" + name + "' (" + m.glslType + "[" +
                              std::to_string(m.arraySize) + "]) has a " + std::to_string(m.arrayStride) +
                              "-byte array stride but " + m.glslType + " is " +
                              std::to_string(m.elementSize) +
                              " bytes in C++: this layout cannot be expressed as a C++ struct (std140 "
                              "rounds array strides up to 16 bytes); use vec4 elements or a std430 block");
                    ok = false;
                    continue;
                }
                m.size = m.elementSize * std::max(m.arraySize, 1u);
            }
            layout.members.push_back(std::move(m));
        }
        if (!ok) return false;
        if (runtimeArray) return true;
        layout.declaredSize = static_cast<uint32_t>(m_compiler.get_declared_struct_size(type));
        m_stage.layouts.push_back(std::move(layout));
        return true;
    }

    static std::string describe(BlockKind kind) {
        switch (kind) {
            case BlockKind::UniformBlock:
                return "uniform block";
            case BlockKind::PushConstant:
                return "push-constant block";
            case BlockKind::StorageBlock:
                return "storage block";
            case BlockKind::Struct:
                return "struct";
        }
        return "struct";
    }

private:
    void error(const std::string& where, const std::string& message) {
        m_diagnostics.push_back(where + ": error: " + message);
    }

    const spirv_cross::Compiler& m_compiler;
    StageOutput& m_stage;
    std::vector<std::string>& m_diagnostics;
    std::set<uint32_t> m_done;
};

bool sameMember(const StructMember& a, const StructMember& b) {
    return a.name == b.name && a.glslType == b.glslType && a.cppType == b.cppType &&
           a.isStruct == b.isStruct && a.arraySize == b.arraySize && a.arrayStride == b.arrayStride &&
           a.offset == b.offset && a.elementSize == b.elementSize;
}

std::string describeMember(const StructMember& m) {
    std::string text = m.glslType + " " + m.name;
    if (m.arraySize > 0) text += "[" + std::to_string(m.arraySize) + "]";
    return text + " at offset " + std::to_string(m.offset);
}

// "" if `here` has the layout of `there`, else what differs first. With `prefixOk` one may have
// more members than the other (the shorter one declares a prefix of the same block).
std::string layoutDifference(const StructLayout& there, const StructLayout& here, bool prefixOk) {
    const size_t common = std::min(there.members.size(), here.members.size());
    for (size_t i = 0; i < common; ++i) {
        if (!sameMember(there.members[i], here.members[i])) {
            return "member " + std::to_string(i) + " is '" + describeMember(here.members[i]) +
                   "' here but '" + describeMember(there.members[i]) + "' there";
        }
    }
    if (prefixOk) return "";
    if (there.members.size() > here.members.size()) {
        return "member '" + describeMember(there.members[common]) + "' is missing here";
    }
    if (here.members.size() > there.members.size()) {
        return "member '" + describeMember(here.members[common]) + "' is extra here";
    }
    if (there.declaredSize != here.declaredSize) {
        return "the size is " + std::to_string(here.declaredSize) + " bytes here but " +
               std::to_string(there.declaredSize) + " there";
    }
    return "";
}

}  // namespace

std::string locateDeclaration(const std::vector<std::string>& files, const std::string& typeName,
                              const std::string& member) {
    const std::regex declaration("\\b(uniform|buffer|struct)\\s+" + typeName + "\\b");
    const std::regex memberName("\\b" + member + "\\s*(\\[|;|,)");
    for (const std::string& file : files) {
        std::ifstream in(file);
        std::vector<std::string> lines;
        for (std::string line; std::getline(in, line);) lines.push_back(stripLineComment(line));
        for (size_t i = 0; i < lines.size(); ++i) {
            std::smatch match;
            if (!std::regex_search(lines[i], match, declaration)) continue;
            const std::string at = file + ":" + std::to_string(i + 1);
            if (member.empty()) return at;
            int depth = 0;
            bool opened = false;
            for (size_t j = i; j < lines.size(); ++j) {
                const std::string text = j == i ? match.suffix().str() : lines[j];
                if (opened && depth == 1 && std::regex_search(text, memberName)) {
                    return file + ":" + std::to_string(j + 1);
                }
                for (char c : text) {
                    if (c == '{') {
                        ++depth;
                        opened = true;
                        // Members on the line of the opening brace.
                        if (depth == 1 && std::regex_search(text.substr(text.find('{')), memberName)) {
                            return file + ":" + std::to_string(j + 1);
                        }
                    } else if (c == '}') {
                        --depth;
                    }
                }
                if (opened && depth <= 0) break;
            }
            return at;
        }
    }
    return files.empty() ? std::string() : files.front();
}

bool reflectLayouts(StageOutput& stage, std::vector<std::string>& diagnostics) {
    try {
        spirv_cross::Compiler compiler(stage.spirv);
        const spirv_cross::ShaderResources resources = compiler.get_shader_resources();
        LayoutReflector reflector(compiler, stage, diagnostics);
        bool ok = true;
        std::string name;
        for (const spirv_cross::Resource& r : resources.uniform_buffers) {
            ok &= reflector.reflect(compiler.get_type(r.base_type_id), BlockKind::UniformBlock,
                                    compiler.get_decoration(r.id, spv::DecorationDescriptorSet),
                                    compiler.get_decoration(r.id, spv::DecorationBinding), name);
        }
        for (const spirv_cross::Resource& r : resources.storage_buffers) {
            ok &= reflector.reflect(compiler.get_type(r.base_type_id), BlockKind::StorageBlock,
                                    compiler.get_decoration(r.id, spv::DecorationDescriptorSet),
                                    compiler.get_decoration(r.id, spv::DecorationBinding), name);
        }
        for (const spirv_cross::Resource& r : resources.push_constant_buffers) {
            if (reflector.reflect(compiler.get_type(r.base_type_id), BlockKind::PushConstant, 0, 0, name)) {
                stage.pushConstantBlock = name;
            } else {
                ok = false;
            }
        }
        return ok;
    } catch (const std::exception& e) {
        diagnostics.push_back(stage.path + ": error: SPIR-V block reflection failed: " + e.what());
        return false;
    }
}

namespace {

// Collects the "where: error: message" diagnostics of the program-interface checks and
// remembers whether any was reported.
class InterfaceErrors {
public:
    explicit InterfaceErrors(std::vector<std::string>& diagnostics) : m_diagnostics(diagnostics) {}

    void report(const std::string& where, const std::string& message) {
        m_diagnostics.push_back(where + ": error: " + message);
        m_ok = false;
    }

    bool ok() const { return m_ok; }

private:
    std::vector<std::string>& m_diagnostics;
    bool m_ok = true;
};

// The program's layouts, one per GLSL type name, and the names in the order first declared.
struct LayoutPool {
    std::map<std::string, StructLayout> layouts;
    std::vector<std::string> firstSeen;
};

// The stages of the program followed by those of each variant.
std::vector<const StageOutput*> allStages(const ProgramOutput& program) {
    std::vector<const StageOutput*> stages;
    for (const StageOutput& s : program.stages) stages.push_back(&s);
    for (const VariantOutput& v : program.variants) {
        for (const StageOutput& s : v.stages) stages.push_back(&s);
    }
    return stages;
}

// Whether a block named View is the shared per-view block; reports why when it is not.
bool matchesViewBlock(const StructLayout& layout, const StructLayout& view, InterfaceErrors& errors) {
    if (layout.kind != BlockKind::UniformBlock) {
        errors.report(layout.origin, std::string("the name '") + kViewBlockName +
                                         "' is reserved for the shared per-view uniform block (" +
                                         "#include \"" + fs::path(view.origin).filename().string() + "\")");
        return false;
    }
    if (layout.set != kViewSet || layout.binding != kViewBinding) {
        errors.report(layout.origin, std::string("uniform block '") + kViewBlockName + "' is at set " +
                                         std::to_string(layout.set) + ", binding " +
                                         std::to_string(layout.binding) +
                                         "; the shared per-view block is at set 0, binding 0");
        return false;
    }
    const std::string difference = layoutDifference(view, layout, false);
    if (!difference.empty()) {
        errors.report(layout.origin, std::string("uniform block '") + kViewBlockName +
                                         "' does not match the shared per-view block declared at " +
                                         view.origin + ": " + difference +
                                         " (#include \"view.glsl\" instead of declaring it)");
        return false;
    }
    return true;
}

// One layout per name (a longer declaration of the same block absorbs a shorter one, as Vulkan
// lets a stage declare only the members it reads); the View block is checked and sets
// program.usesView instead of entering the pool.
LayoutPool mergeLayouts(const std::vector<const StageOutput*>& stages, const StructLayout* view,
                        ProgramOutput& program, InterfaceErrors& errors) {
    LayoutPool pool;
    program.usesView = false;
    for (const StageOutput* stage : stages) {
        for (const StructLayout& layout : stage->layouts) {
            if (view && layout.name == kViewBlockName) {
                if (matchesViewBlock(layout, *view, errors)) program.usesView = true;
                continue;
            }
            auto it = pool.layouts.find(layout.name);
            if (it == pool.layouts.end()) {
                pool.layouts.emplace(layout.name, layout);
                pool.firstSeen.push_back(layout.name);
                continue;
            }
            StructLayout& existing = it->second;
            const bool longer = layout.members.size() > existing.members.size();
            const std::string difference = layoutDifference(existing, layout, true);
            if (!difference.empty()) {
                errors.report(
                    layout.origin,
                    "'" + layout.name + "' has a different layout here than at " + existing.origin + ": " +
                        difference +
                        "; a program gets one C++ struct per GLSL type name, so rename one of them");
                continue;
            }
            if (longer) {
                existing.members = layout.members;
                existing.declaredSize = layout.declaredSize;
                existing.origin = layout.origin;
            }
        }
    }
    return pool;
}

// Push constants: one block name for the whole program.
void resolvePushConstantBlock(const std::vector<const StageOutput*>& stages, ProgramOutput& program,
                              InterfaceErrors& errors) {
    program.pushConstantStruct.clear();
    std::string pushOrigin;
    for (const StageOutput* stage : stages) {
        if (stage->pushConstantBlock.empty()) continue;
        if (program.pushConstantStruct.empty()) {
            program.pushConstantStruct = stage->pushConstantBlock;
            pushOrigin = stage->path;
        } else if (program.pushConstantStruct != stage->pushConstantBlock) {
            errors.report(stage->path, "the push-constant block is '" + stage->pushConstantBlock +
                                           "' here but '" + program.pushConstantStruct + "' in " +
                                           pushOrigin +
                                           "; the stages of a program share one push-constant block type");
        }
    }
}

// The array stride of each struct that appears as an array element (runtime arrays of blocks,
// then struct arrays inside the pooled layouts); one struct cannot have two strides.
std::map<std::string, uint32_t> collectArrayStrides(const std::vector<const StageOutput*>& stages,
                                                    const LayoutPool& pool, InterfaceErrors& errors) {
    std::map<std::string, uint32_t> strides;
    for (const StageOutput* stage : stages) {
        for (const StructLayout& layout : stage->layouts) {
            if (layout.runtimeArrayStride == 0) continue;
            auto [it, inserted] = strides.emplace(layout.name, layout.runtimeArrayStride);
            if (!inserted && it->second != layout.runtimeArrayStride) {
                errors.report(layout.origin, "arrays of struct '" + layout.name + "' have strides of " +
                                                 std::to_string(it->second) + " and " +
                                                 std::to_string(layout.runtimeArrayStride) +
                                                 " bytes: one C++ struct cannot have both sizes");
            }
        }
    }
    for (const std::string& name : pool.firstSeen) {
        for (const StructMember& m : pool.layouts.at(name).members) {
            if (!m.isStruct || m.arraySize == 0) continue;
            auto [it, inserted] = strides.emplace(m.cppType, m.arrayStride);
            if (!inserted && it->second != m.arrayStride) {
                errors.report(pool.layouts.at(name).origin,
                              "arrays of struct '" + m.cppType + "' have strides of " +
                                  std::to_string(it->second) + " and " + std::to_string(m.arrayStride) +
                                  " bytes: one C++ struct cannot have both sizes");
            }
        }
    }
    return strides;
}

// The pooled struct names with every nested struct before the structs that contain it.
std::vector<std::string> dependencyOrder(const LayoutPool& pool) {
    std::vector<std::string> order;
    std::set<std::string> visiting, done;
    std::function<void(const std::string&)> visit = [&](const std::string& name) {
        if (done.count(name) || visiting.count(name)) return;
        visiting.insert(name);
        for (const StructMember& m : pool.layouts.at(name).members) {
            if (m.isStruct && pool.layouts.count(m.cppType)) visit(m.cppType);
        }
        visiting.erase(name);
        done.insert(name);
        order.push_back(name);
    };
    for (const std::string& name : pool.firstSeen) visit(name);
    return order;
}

// Sizes of the struct members and of the struct `name` (its nested structs already sized):
// members may not overlap in C++, and the size is padded to its array stride and to 4 bytes.
void sizeStruct(const std::string& name, LayoutPool& pool, const std::map<std::string, uint32_t>& strides,
                InterfaceErrors& errors) {
    StructLayout& layout = pool.layouts.at(name);
    uint32_t end = 0;
    for (size_t i = 0; i < layout.members.size(); ++i) {
        StructMember& m = layout.members[i];
        if (m.isStruct) {
            auto nested = pool.layouts.find(m.cppType);
            if (nested == pool.layouts.end()) {
                errors.report(layout.origin, "internal: struct '" + m.cppType + "' was not reflected");
                continue;
            }
            m.elementSize = nested->second.size;
            if (m.arraySize > 0 && m.arrayStride != m.elementSize) {
                errors.report(m.origin, "member '" + m.name + "' of '" + name + "': struct '" + m.cppType +
                                            "' is " + std::to_string(m.elementSize) +
                                            " bytes in C++ but its array stride is " +
                                            std::to_string(m.arrayStride));
                continue;
            }
            m.size = m.elementSize * std::max(m.arraySize, 1u);
        }
        if (m.offset < end) {
            errors.report(m.origin, "member '" + m.name + "' of '" + name + "' at offset " +
                                        std::to_string(m.offset) +
                                        " overlaps the previous member, which ends at " +
                                        std::to_string(end) + " in C++: this layout cannot be expressed");
        }
        end = m.offset + m.size;
    }
    uint32_t size = std::max(end, layout.declaredSize);
    auto stride = strides.find(name);
    if (stride != strides.end()) {
        if (stride->second < size) {
            errors.report(layout.origin, "struct '" + name + "' is " + std::to_string(size) +
                                             " bytes but an array of it has a stride of " +
                                             std::to_string(stride->second) + " bytes");
        }
        size = std::max(size, stride->second);
    }
    layout.size = (size + 3u) & ~3u;
}

// Named slots: one (set, binding) per binding name over all stages and variants, sorted by
// (set, binding, name) into program.slots.
void resolveSlots(const std::vector<const StageOutput*>& stages, ProgramOutput& program,
                  InterfaceErrors& errors) {
    std::map<std::string, std::pair<Binding, std::string>> slots;
    for (const StageOutput* stage : stages) {
        for (const Binding& b : stage->bindings) {
            auto [it, inserted] = slots.emplace(b.name, std::make_pair(b, stage->path));
            if (inserted) {
                if (isCppOnlyKeyword(b.name)) {
                    errors.report(stage->path, "binding name '" + b.name + "' is a C++ keyword; rename it");
                }
                continue;
            }
            const Binding& a = it->second.first;
            if (a.set != b.set || a.binding != b.binding || a.type != b.type || a.count != b.count) {
                errors.report(stage->path, "the name '" + b.name + "' means set " + std::to_string(b.set) +
                                               ", binding " + std::to_string(b.binding) + " here but set " +
                                               std::to_string(a.set) + ", binding " +
                                               std::to_string(a.binding) + " in " + it->second.second +
                                               " (or a different type or count): a name must mean one slot");
            }
        }
    }
    program.slots.clear();
    for (const auto& [name, entry] : slots) program.slots.push_back(entry.first);
    std::sort(program.slots.begin(), program.slots.end(), [](const Binding& a, const Binding& b) {
        return std::tie(a.set, a.binding, a.name) < std::tie(b.set, b.binding, b.name);
    });
}

}  // namespace

bool resolveProgramInterface(ProgramOutput& program, const StructLayout* view,
                             std::vector<std::string>& diagnostics) {
    const std::vector<const StageOutput*> stages = allStages(program);
    InterfaceErrors errors(diagnostics);

    LayoutPool pool = mergeLayouts(stages, view, program, errors);
    resolvePushConstantBlock(stages, program, errors);
    if (!errors.ok()) return false;

    // Struct sizes: an array of structs pads its element struct to the array stride; sizes depend
    // on nested structs, so they are resolved in dependency order.
    const std::map<std::string, uint32_t> strides = collectArrayStrides(stages, pool, errors);
    if (!errors.ok()) return false;
    const std::vector<std::string> order = dependencyOrder(pool);
    for (const std::string& name : order) sizeStruct(name, pool, strides, errors);
    if (!errors.ok()) return false;
    program.structs.clear();
    for (const std::string& name : order) program.structs.push_back(pool.layouts.at(name));

    resolveSlots(stages, program, errors);
    return errors.ok();
}

}  // namespace penumbra::shaderc::detail
