// Shader variants: `#pragma penumbra_variants DEFINE [DEFINE_A+DEFINE_B ...]` lines in the stage
// sources of a program. Each entry is one variant compiled with those defines (#define X 1); the
// Default variant (no defines) always exists.
#include "internal.h"

#include <cctype>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

namespace penumbra::shaderc::detail {
namespace {

bool isMacroName(const std::string& s) {
    if (s.empty() || std::isdigit(static_cast<unsigned char>(s.front()))) return false;
    for (char c : s) {
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
    }
    return true;
}

// ALBEDO_ONLY -> AlbedoOnly; an all-caps part is lowered after its first letter, a mixed-case
// part (albedoOnly) keeps its case after the first letter.
std::string pascalCase(const std::string& define) {
    std::string out;
    std::string part;
    auto flush = [&] {
        if (part.empty()) return;
        bool hasLower = false;
        for (char c : part) hasLower |= std::islower(static_cast<unsigned char>(c)) != 0;
        out += static_cast<char>(std::toupper(static_cast<unsigned char>(part[0])));
        for (size_t i = 1; i < part.size(); ++i) {
            out += hasLower ? part[i] : static_cast<char>(std::tolower(static_cast<unsigned char>(part[i])));
        }
        part.clear();
    };
    for (char c : define) {
        if (c == '_') {
            flush();
        } else {
            part += c;
        }
    }
    flush();
    return out;
}

}  // namespace

bool parseVariantPragmas(const std::vector<StageInput>& stages, std::vector<VariantOutput>& variants,
                         std::vector<std::string>& diagnostics) {
    static const std::regex kPragma(R"(^\s*#\s*pragma\s+penumbra_variants\b(.*)$)");
    bool ok = true;
    std::map<std::string, size_t> byName;
    for (const StageInput& input : stages) {
        std::ifstream in(input.path);
        if (!in) continue;  // compileToSpirv reports the unreadable file
        size_t lineNumber = 0;
        for (std::string line; std::getline(in, line);) {
            ++lineNumber;
            std::smatch match;
            if (!std::regex_match(line, match, kPragma)) continue;
            const std::string where = input.path + ":" + std::to_string(lineNumber);
            std::string rest = match[1].str();
            const size_t comment = rest.find("//");
            if (comment != std::string::npos) rest.resize(comment);
            std::istringstream tokens(rest);
            bool any = false;
            for (std::string token; tokens >> token;) {
                any = true;
                VariantOutput variant;
                variant.origin = where;
                std::string define;
                std::istringstream parts(token);
                bool valid = true;
                while (std::getline(parts, define, '+')) {
                    if (!isMacroName(define) || define.rfind("GL_", 0) == 0 ||
                        define.find("__") != std::string::npos) {
                        diagnostics.push_back(
                            where + ": error: '" + define + "' in '" + token +
                            "' is not a usable macro name (an identifier, not starting with "
                            "GL_ and without '__')");
                        valid = false;
                        break;
                    }
                    variant.defines.push_back(define);
                    variant.name += pascalCase(define);
                }
                if (!valid || variant.defines.empty()) {
                    if (valid) diagnostics.push_back(where + ": error: empty variant '" + token + "'");
                    ok = false;
                    continue;
                }
                if (variant.name == "Default") {
                    diagnostics.push_back(
                        where + ": error: variant '" + token +
                        "' would be called Default, the name of the variant without defines");
                    ok = false;
                    continue;
                }
                auto it = byName.find(variant.name);
                if (it != byName.end()) {
                    // The vertex and fragment source may both declare the program's variants.
                    if (variants[it->second].defines != variant.defines) {
                        diagnostics.push_back(where + ": error: variant '" + token +
                                              "' and the variant declared at " + variants[it->second].origin +
                                              " are both called " + variant.name);
                        ok = false;
                    }
                    continue;
                }
                byName.emplace(variant.name, variants.size());
                variants.push_back(std::move(variant));
            }
            if (!any) {
                diagnostics.push_back(where + ": error: #pragma penumbra_variants names no define");
                ok = false;
            }
        }
    }
    return ok;
}

}  // namespace penumbra::shaderc::detail
