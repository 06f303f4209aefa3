/* The single translation unit that instantiates the stb image writer (Debian's libstb-dev). */
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
