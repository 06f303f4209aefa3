#include "engine/image/image.h"

#include <png.h>
#include <stb_image_write.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

namespace penumbra {

bool writePng(const std::string& path, const ImageRGBA8& image, std::string* error) {
    auto fail = [&](const std::string& why) {
        if (error) *error = path + ": " + why;
        return false;
    };
    if (image.empty() || image.pixels.size() != size_t(image.width) * image.height * 4)
        return fail("image is empty or its pixel buffer does not match its size");
    std::error_code ec;
    auto parent = std::filesystem::path(path).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    if (ec) return fail("cannot create directory: " + ec.message());
    if (!stbi_write_png(path.c_str(), int(image.width), int(image.height), 4, image.pixels.data(),
                        int(image.width * 4)))
        return fail("cannot write PNG");
    return true;
}

namespace {
struct PngErrorState {
    std::jmp_buf jump;
    std::string message;
};
void pngError(png_structp png, png_const_charp msg) {
    auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
    state->message = msg;
    std::longjmp(state->jump, 1);
}
void pngWarning(png_structp, png_const_charp) {}

// Bytes of a PNG held in memory, consumed by pngReadMemory.
struct PngMemorySource {
    const uint8_t* data = nullptr;
    size_t size = 0;
    size_t offset = 0;
};
void pngReadMemory(png_structp png, png_bytep out, png_size_t count) {
    auto* src = static_cast<PngMemorySource*>(png_get_io_ptr(png));
    if (count > src->size - src->offset) png_error(png, "truncated data (unexpected end of the image)");
    std::memcpy(out, src->data + src->offset, count);
    src->offset += count;
}

// Decodes the PNG after its 8-byte signature, from `file` or else from `memory`. False with the
// reason in `message` (libpng's text, if any).
bool decodePng(FILE* file, PngMemorySource* memory, ImageRGBA8& out, std::string& message) {
    PngErrorState state;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state, pngError, pngWarning);
    if (!png) {
        message = "out of memory";
        return false;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_read_struct(&png, nullptr, nullptr);
        message = "out of memory";
        return false;
    }
    // Everything that may longjmp lives between setjmp and the destroy call below; no C++ objects
    // with destructors are created in that range.
    std::vector<png_bytep>* rows = new std::vector<png_bytep>();
    ImageRGBA8* img = new ImageRGBA8();
    volatile bool ok = false;  // modified between setjmp and a possible longjmp
    if (setjmp(state.jump) == 0) {
        png_set_user_limits(png, 16384, 16384);
        if (file) {
            png_init_io(png, file);
        } else {
            png_set_read_fn(png, memory, pngReadMemory);
        }
        png_set_sig_bytes(png, 8);
        png_read_info(png, info);
        png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
        int depth = png_get_bit_depth(png, info), color = png_get_color_type(png, info);
        if (uint64_t(w) * h > kMaxPngPixels) png_error(png, "image too large");
        if (depth == 16) png_set_strip_16(png);
        if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
        if (color == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
        if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
        if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
        if (!(color & PNG_COLOR_MASK_ALPHA) && !png_get_valid(png, info, PNG_INFO_tRNS))
            png_set_filler(png, 0xff, PNG_FILLER_AFTER);
        png_set_interlace_handling(png);
        png_read_update_info(png, info);
        if (png_get_rowbytes(png, info) != size_t(w) * 4) png_error(png, "unexpected row layout");
        img->width = w;
        img->height = h;
        img->pixels.resize(size_t(w) * h * 4);
        rows->resize(h);
        for (png_uint_32 y = 0; y < h; ++y) (*rows)[y] = img->pixels.data() + size_t(y) * w * 4;
        png_read_image(png, rows->data());
        png_read_end(png, nullptr);
        ok = true;
    }
    png_destroy_read_struct(&png, &info, nullptr);
    delete rows;
    if (ok) out = std::move(*img);
    delete img;
    if (!ok) message = state.message;
    return ok;
}
}  // namespace

bool readPng(const std::string& path, ImageRGBA8& out, std::string* error) {
    auto fail = [&](const std::string& why) {
        if (error) *error = path + ": " + why;
        return false;
    };
    std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!file) return fail("cannot open file");
    png_byte header[8];
    if (std::fread(header, 1, 8, file.get()) != 8 || png_sig_cmp(header, 0, 8) != 0)
        return fail("not a PNG file");
    std::string message;
    if (!decodePng(file.get(), nullptr, out, message))
        return fail(message.empty() ? "corrupt PNG" : "corrupt PNG (" + message + ")");
    return true;
}

bool readPngMemory(const uint8_t* data, size_t size, const std::string& name, ImageRGBA8& out,
                   std::string* error) {
    auto fail = [&](const std::string& why) {
        if (error) {
            *error = name;
            error->append(": ").append(why);
        }
        return false;
    };
    if (!data || size < 8 || png_sig_cmp(data, 0, 8) != 0) return fail("not a PNG file");
    PngMemorySource source{data, size, 8};
    std::string message;
    if (!decodePng(nullptr, &source, out, message))
        return fail(message.empty() ? "corrupt PNG" : "corrupt PNG (" + message + ")");
    return true;
}

}  // namespace penumbra
