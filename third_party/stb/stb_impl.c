/* The single translation unit that instantiates stb (Debian's libstb-dev headers):
 *  - the image writer (PNG output),
 *  - a JPEG-only image decoder for textures (engine/assets/texture.cpp). Its functions are static
 *    (STB_IMAGE_STATIC) so they never interpose the libstb.so that Debian's tinygltf links; the
 *    engine calls them through the penumbra_jpeg_* wrappers below. No stdio, no HDR/linear
 *    paths; dimensions above 16384 are refused by stb itself as a last line of defence (callers
 *    check the header against their own limits first). */
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#define STBI_NO_LINEAR
#define STBI_NO_HDR
#define STBI_MAX_DIMENSIONS 16384
#include <stb_image.h>

/* Width, height and component count from the JPEG header, without decoding. 1 on success. */
int penumbra_jpeg_info(const unsigned char* data, int size, int* width, int* height, int* components) {
    return stbi_info_from_memory(data, size, width, height, components);
}

/* Decodes to 8-bit RGBA (row 0 = top); free the result with penumbra_jpeg_free. Null on failure. */
unsigned char* penumbra_jpeg_load_rgba8(const unsigned char* data, int size, int* width, int* height) {
    int components = 0;
    return stbi_load_from_memory(data, size, width, height, &components, 4);
}

void penumbra_jpeg_free(unsigned char* pixels) { stbi_image_free(pixels); }

/* The reason for the last failure (a short English phrase). */
const char* penumbra_jpeg_failure_reason(void) { return stbi_failure_reason(); }
