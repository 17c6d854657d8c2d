// write_png: an Image's colour as 8-bit sRGB RGBA through stb_image_write.
#include <stb_image_write.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "preprocess/atomic_file.h"
#include "engine/io/image.h"

namespace strata {
namespace {

float clamp_unit(float value) { return std::isnan(value) ? 0.0f : std::fmin(std::fmax(value, 0.0f), 1.0f); }

// The exact piecewise sRGB curve (IEC 61966-2-1), in double so rounding lands on the nearest byte.
// (A table of the 255 rounding thresholds gives the same bytes for every float, but saves only a
// fifth of a second on a 4K frame whose deflate takes over a second: not worth its code.)
uint8_t encode_srgb(float linear) {
    const double c = clamp_unit(linear);
    return uint8_t(std::lround(255.0 * (c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055)));
}

uint8_t encode_alpha(float alpha) { return uint8_t(std::lround(255.0f * clamp_unit(alpha))); }

// stb calls this from C: it must not throw; AtomicOutputFile::write keeps the failure for commit().
void write_to_file(void* file, void* data, int size) {
    static_cast<AtomicOutputFile*>(file)->write(data, size_t(size));
}

}  // namespace

std::vector<uint8_t> encode_srgb_rgba8(const Image& image) {
    image.check_sizes();
    if (!image.has(ImageChannel::rgba)) throw std::invalid_argument("the image has no RGBA plane to encode");
    std::vector<uint8_t> bytes(image.rgba.size());
    for (size_t i = 0; i < bytes.size(); i += 4) {
        for (size_t k = 0; k < 3; ++k) bytes[i + k] = encode_srgb(image.rgba[i + k]);
        bytes[i + 3] = encode_alpha(image.rgba[i + 3]);
    }
    return bytes;
}

void write_png(const Image& image, const std::filesystem::path& path) {
    if (!image.has(ImageChannel::rgba)) throw std::invalid_argument("cannot write a PNG: the image has no RGBA plane");
    write_png_rgba8(encode_srgb_rgba8(image), image.width, image.height, path);
}

void write_png_rgba8(const std::vector<uint8_t>& pixels, int width, int height, const std::filesystem::path& path) {
    if (width <= 0 || height <= 0 || pixels.size() != size_t(width) * size_t(height) * 4)
        throw std::invalid_argument("cannot write a PNG: " + std::to_string(pixels.size()) + " bytes for " +
                                    std::to_string(width) + "x" + std::to_string(height) + " RGBA pixels");
    AtomicOutputFile file(path);
    if (!stbi_write_png_to_func(write_to_file, &file, width, height, 4, pixels.data(), 4 * width))
        file.fail("PNG encoding failed");
    file.commit();
}

}  // namespace strata
