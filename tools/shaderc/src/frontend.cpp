// glslang front end: GLSL 450 with Vulkan semantics -> SPIR-V, #include resolution, diagnostics
// mapped to real file paths and lines, SPIR-V validation, and the desktop-GLSL self check.
#include "internal.h"

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
#include <spirv-tools/libspirv.hpp>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>

namespace fs = std::filesystem;

namespace penumbra::shaderc::detail {
namespace {

constexpr size_t kMaxIncludeDepth = 32;

EShLanguage toLanguage(rhi::ShaderStage stage) {
    switch (stage) {
        case rhi::ShaderStage::Vertex:
            return EShLangVertex;
        case rhi::ShaderStage::Fragment:
            return EShLangFragment;
        case rhi::ShaderStage::Compute:
            return EShLangCompute;
    }
    return EShLangCompute;
}

bool readFile(const fs::path& path, std::string& out) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    std::ostringstream ss;
    ss << in.rdbuf();
    out = ss.str();
    return !in.bad();
}

std::string normalizedPath(const fs::path& p) {
    std::error_code ec;
    fs::path abs = fs::absolute(p, ec);
    return (ec ? p : abs).lexically_normal().string();
}

// Resolves `#include "x"` against the including file's directory, then the include directories;
// `#include <x>` against the include directories only. Records every file it opens in knownNames.
class FileIncluder final : public glslang::TShader::Includer {
public:
    FileIncluder(const std::vector<std::string>& includeDirs, std::vector<std::string>& knownNames)
        : m_includeDirs(includeDirs), m_knownNames(knownNames) {}

    IncludeResult* includeLocal(const char* headerName, const char* includerName, size_t depth) override {
        return resolve(headerName, includerName, depth, true);
    }
    IncludeResult* includeSystem(const char* headerName, const char* includerName, size_t depth) override {
        return resolve(headerName, includerName, depth, false);
    }
    void releaseInclude(IncludeResult* result) override {
        if (!result) return;
        delete static_cast<std::string*>(result->userData);
        delete result;
    }

private:
    IncludeResult* fail(const std::string& message) {
        auto* text = new std::string(message);
        return new IncludeResult(std::string(), text->data(), text->size(), text);
    }

    IncludeResult* resolve(const char* headerName, const char* includerName, size_t depth, bool local) {
        if (depth > kMaxIncludeDepth) {
            return fail("#include nested more than " + std::to_string(kMaxIncludeDepth) +
                        " levels deep (recursive include?)");
        }
        std::vector<fs::path> candidates;
        if (local && includerName && *includerName) {
            candidates.push_back(fs::path(includerName).parent_path() / headerName);
        }
        for (const std::string& dir : m_includeDirs) candidates.push_back(fs::path(dir) / headerName);

        for (const fs::path& candidate : candidates) {
            std::error_code ec;
            if (!fs::is_regular_file(candidate, ec)) continue;
            auto* content = new std::string();
            if (!readFile(candidate, *content)) {
                delete content;
                return fail("cannot read included file " + candidate.string());
            }
            std::string resolved = normalizedPath(candidate);
            m_knownNames.push_back(resolved);
            return new IncludeResult(resolved, content->data(), content->size(), content);
        }
        std::vector<std::string> searched;
        for (const fs::path& c : candidates) searched.push_back(c.lexically_normal().parent_path().string());
        if (local) {
            // glslang retries a failed local include as a system include; report both searches there.
            m_localSearch = {headerName, searched};
            return nullptr;
        }
        std::string list;
        if (m_localSearch.first == headerName) {
            for (const std::string& dir : m_localSearch.second) list += (list.empty() ? "" : ", ") + dir;
        } else {
            for (const std::string& dir : searched) list += (list.empty() ? "" : ", ") + dir;
        }
        return fail(std::string("cannot find included file '") + headerName + "' (searched " + list + ")");
    }

    const std::vector<std::string>& m_includeDirs;
    std::vector<std::string>& m_knownNames;
    std::pair<std::string, std::vector<std::string>> m_localSearch;  // last failed local include
};

// Converts a glslang info log ("ERROR: <name>:<line>: <message>") into `name:line: error: message`
// lines. `knownNames` are the exact names glslang can print (the source path and every resolved
// include); the numeric string index 0 (no name) maps to `fallbackPath`.
void translateLog(const std::string& log, const std::vector<std::string>& knownNames,
                  const std::string& fallbackPath, std::vector<std::string>& diagnostics, bool& sawError) {
    std::vector<std::string> names = knownNames;
    std::sort(names.begin(), names.end(), [](const std::string& a, const std::string& b) {
        return a.size() > b.size();  // longest first, so a prefix never shadows a longer name
    });

    std::istringstream lines(log);
    std::string line;
    std::vector<std::string> unlocated;
    while (std::getline(lines, line)) {
        while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
        if (line.empty()) continue;

        std::string severity = "error";
        std::string rest = line;
        struct Prefix {
            const char* text;
            const char* severity;
        };
        static constexpr Prefix kPrefixes[] = {{"ERROR: ", "error"},
                                               {"INTERNAL ERROR: ", "error"},
                                               {"UNIMPLEMENTED: ", "error"},
                                               {"WARNING: ", "warning"},
                                               {"NOTE: ", "note"}};
        bool prefixed = false;
        for (const Prefix& p : kPrefixes) {
            if (rest.rfind(p.text, 0) == 0) {
                severity = p.severity;
                rest = rest.substr(std::char_traits<char>::length(p.text));
                prefixed = true;
                break;
            }
        }
        if (!prefixed) {
            unlocated.push_back(line);
            continue;
        }
        if (severity == "error") sawError = true;

        // Location: a known name or a decimal string index, then ":<line>: ".
        std::string file;
        size_t pos = std::string::npos;
        for (const std::string& name : names) {
            if (rest.size() > name.size() && rest.compare(0, name.size(), name) == 0 &&
                rest[name.size()] == ':') {
                file = name;
                pos = name.size() + 1;
                break;
            }
        }
        if (pos == std::string::npos) {
            size_t digits = 0;
            while (digits < rest.size() && std::isdigit(static_cast<unsigned char>(rest[digits]))) ++digits;
            if (digits > 0 && digits < rest.size() && rest[digits] == ':') {
                file = fallbackPath;
                pos = digits + 1;
            }
        }
        size_t lineEnd = pos;
        if (pos != std::string::npos) {
            while (lineEnd < rest.size() && std::isdigit(static_cast<unsigned char>(rest[lineEnd])))
                ++lineEnd;
        }
        if (pos == std::string::npos || lineEnd == pos || lineEnd >= rest.size() || rest[lineEnd] != ':') {
            // No location ("ERROR: 2 compilation errors.  No code generated.", link errors).
            if (rest.find("compilation errors") != std::string::npos &&
                rest.find("No code generated") != std::string::npos)
                continue;
            unlocated.push_back(fallbackPath + ": " + severity + ": " + rest);
            continue;
        }
        std::string lineNumber = rest.substr(pos, lineEnd - pos);
        std::string message = rest.substr(lineEnd + 1);
        while (!message.empty() && message.front() == ' ') message.erase(message.begin());
        if (message.find("compilation terminated") != std::string::npos) continue;
        diagnostics.push_back(file + ":" + lineNumber + ": " + severity + ": " + message);
    }
    for (const std::string& u : unlocated) {
        // Lines without a glslang severity prefix (continuations, summaries) are attributed to the
        // source as notes so they still read as `path: note: ...`.
        diagnostics.push_back(u.rfind(fallbackPath + ":", 0) == 0 ? u : fallbackPath + ": note: " + u);
    }
}

}  // namespace

void ensureGlslangInitialized() {
    static std::once_flag once;
    std::call_once(once, [] {
        glslang::InitializeProcess();
        std::atexit([] { glslang::FinalizeProcess(); });
    });
}

const char* stageFileKind(rhi::ShaderStage stage) {
    switch (stage) {
        case rhi::ShaderStage::Vertex:
            return "vert";
        case rhi::ShaderStage::Fragment:
            return "frag";
        case rhi::ShaderStage::Compute:
            return "comp";
    }
    return "comp";
}

bool compileToSpirv(const StageInput& input, const std::vector<std::string>& includeDirs,
                    const std::vector<std::string>& defines, const std::string* sourceText,
                    std::vector<uint32_t>& spirv, std::vector<std::string>& files,
                    std::vector<std::string>& diagnostics) {
    ensureGlslangInitialized();

    std::string source;
    if (sourceText) {
        source = *sourceText;
    } else {
        if (!readFile(input.path, source)) {
            diagnostics.push_back(input.path + ": error: cannot read shader source");
            return false;
        }
        files.push_back(normalizedPath(input.path));
    }
    const EShLanguage language = toLanguage(input.stage);
    glslang::TShader shader(language);
    const char* text = source.c_str();
    const int length = static_cast<int>(source.size());
    const char* name = input.path.c_str();
    shader.setStringsWithLengthsAndNames(&text, &length, &name, 1);
    std::string preamble = "#extension GL_GOOGLE_include_directive : require\n";
    for (const std::string& define : defines) preamble += "#define " + define + " 1\n";
    shader.setPreamble(preamble.c_str());
    shader.setEntryPoint("main");
    shader.setEnvInput(glslang::EShSourceGlsl, language, glslang::EShClientVulkan, 100);
    shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_3);
    shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_6);

    std::vector<std::string> knownNames{input.path};
    FileIncluder includer(includeDirs, knownNames);
    const auto messages = static_cast<EShMessages>(EShMsgSpvRules | EShMsgVulkanRules);
    const bool parsed =
        shader.parse(GetDefaultResources(), 450, ECoreProfile, false, false, messages, includer);
    bool sawError = false;
    translateLog(shader.getInfoLog(), knownNames, input.path, diagnostics, sawError);
    // knownNames[0] is the source as given; the rest are the resolved includes in opening order.
    for (size_t i = 1; i < knownNames.size(); ++i) {
        if (std::find(files.begin(), files.end(), knownNames[i]) == files.end())
            files.push_back(knownNames[i]);
    }
    if (!parsed) {
        if (!sawError) diagnostics.push_back(input.path + ": error: GLSL compilation failed");
        return false;
    }

    glslang::TProgram program;
    program.addShader(&shader);
    const bool linked = program.link(messages);
    sawError = false;
    translateLog(program.getInfoLog(), knownNames, input.path, diagnostics, sawError);
    if (!linked) {
        if (!sawError) diagnostics.push_back(input.path + ": error: GLSL link failed");
        return false;
    }

    glslang::SpvOptions options;
    options.generateDebugInfo = false;
    options.disableOptimizer = true;
    options.validate = false;  // validated below with the SPIRV-Tools library directly
    spv::SpvBuildLogger logger;
    spirv.clear();
    glslang::GlslangToSpv(*program.getIntermediate(language), spirv, &logger, &options);
    const std::string spvMessages = logger.getAllMessages();
    if (!spvMessages.empty()) {
        std::istringstream ls(spvMessages);
        std::string l;
        while (std::getline(ls, l))
            if (!l.empty()) diagnostics.push_back(input.path + ": warning: SPIR-V generation: " + l);
    }
    if (spirv.empty()) {
        diagnostics.push_back(input.path + ": error: SPIR-V generation produced no code");
        return false;
    }

    spvtools::SpirvTools tools(SPV_ENV_VULKAN_1_3);
    bool valid = true;
    tools.SetMessageConsumer(
        [&](spv_message_level_t level, const char*, const spv_position_t& position, const char* message) {
            const bool isError = level <= SPV_MSG_ERROR;
            if (isError) valid = false;
            diagnostics.push_back(input.path + ": " + (isError ? "error" : "warning") +
                                  ": invalid SPIR-V (instruction " + std::to_string(position.index) +
                                  "): " + message);
        });
    if (!tools.Validate(spirv.data(), spirv.size(), spvtools::ValidatorOptions())) valid = false;
    if (!valid) {
        diagnostics.push_back(input.path + ": error: generated SPIR-V failed validation");
        return false;
    }
    return true;
}

bool checkDesktopGlsl(const std::vector<StageOutput>& stages, std::vector<std::string>& diagnostics) {
    ensureGlslangInitialized();
    std::vector<std::unique_ptr<glslang::TShader>> shaders;
    glslang::TProgram program;
    bool ok = true;
    for (const StageOutput& stage : stages) {
        const EShLanguage language = toLanguage(stage.stage);
        auto shader = std::make_unique<glslang::TShader>(language);
        const char* text = stage.glsl.c_str();
        const int length = static_cast<int>(stage.glsl.size());
        const std::string name = "generated OpenGL GLSL of " + stage.path;
        const char* namePtr = name.c_str();
        shader->setStringsWithLengthsAndNames(&text, &length, &namePtr, 1);
        shader->setEntryPoint("main");
        glslang::TShader::ForbidIncluder noIncludes;
        if (!shader->parse(GetDefaultResources(), 450, ECoreProfile, false, false, EShMsgDefault,
                           noIncludes)) {
            bool sawError = false;
            translateLog(shader->getInfoLog(), {name}, name, diagnostics, sawError);
            diagnostics.push_back(stage.path +
                                  ": error: internal: the generated OpenGL GLSL does not compile as desktop "
                                  "GLSL 4.50 (see the messages above)");
            ok = false;
            continue;
        }
        program.addShader(shader.get());
        shaders.push_back(std::move(shader));
    }
    if (!ok) return false;
    if (!program.link(EShMsgDefault)) {
        bool sawError = false;
        translateLog(program.getInfoLog(), {}, stages.front().path, diagnostics, sawError);
        diagnostics.push_back(
            stages.front().path +
            ": error: the generated OpenGL GLSL stages do not link as one desktop GLSL program");
        return false;
    }
    return true;
}

}  // namespace penumbra::shaderc::detail
