// A nesting-depth check for JSON text, run before a DOM parser sees it (a deeply nested document
// would otherwise recurse the parser off the stack). Brackets inside strings do not count.
#pragma once

#include <cstddef>
#include <string_view>

namespace penumbra {

// True when no array/object is nested deeper than `maxDepth`; otherwise false with `offset` set to
// the first bracket that is too deep.
inline bool jsonDepthWithin(std::string_view text, int maxDepth, size_t& offset) {
    int depth = 0;
    bool inString = false;
    for (size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (inString) {
            if (c == '\\') {
                ++i;
            } else if (c == '"') {
                inString = false;
            }
        } else if (c == '"') {
            inString = true;
        } else if (c == '[' || c == '{') {
            if (++depth > maxDepth) {
                offset = i;
                return false;
            }
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
    return true;
}

}  // namespace penumbra
