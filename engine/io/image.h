// A rendered frame (colour plus optional depth, normal, HLOD level and node id planes) and its output
// to PNG (8-bit sRGB) and OpenEXR (linear, any subset of the planes).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <vector>

namespace strata {

// The planes a frame can carry; also the channel groups a caller asks an EXR file to hold.
enum class ImageChannel : uint8_t { rgba, depth, normals, level, node_id };

// A set of ImageChannel values (bit flags).
class ImageChannels {
public:
    constexpr ImageChannels() = default;
    constexpr ImageChannels(ImageChannel channel) : bits_(bit(channel)) {}
    constexpr ImageChannels(std::initializer_list<ImageChannel> channels) {
        for (ImageChannel c : channels) bits_ |= bit(c);
    }
    static constexpr ImageChannels all() {
        return {ImageChannel::rgba, ImageChannel::depth, ImageChannel::normals, ImageChannel::level,
                ImageChannel::node_id};
    }

    constexpr bool contains(ImageChannel channel) const { return bits_ & bit(channel); }
    constexpr bool empty() const { return bits_ == 0; }
    constexpr ImageChannels& operator|=(ImageChannels other) {
        bits_ |= other.bits_;
        return *this;
    }
    friend constexpr ImageChannels operator|(ImageChannels a, ImageChannels b) { return a |= b; }
    constexpr bool operator==(const ImageChannels&) const = default;

private:
    static constexpr uint8_t bit(ImageChannel channel) { return uint8_t(1u << unsigned(channel)); }
    uint8_t bits_ = 0;
};

// The name a channel has on the command line and in Lua: "RGBA", "Z", "N", "level", "id".
std::string channel_name(ImageChannel channel);

// How many values one pixel has in the plane: 4 for rgba, 3 for normals, else 1.
size_t values_per_pixel(ImageChannel plane);

// Parses comma-separated channel names ("RGBA,Z,N", case-insensitive, blanks around names ignored).
// Throws std::invalid_argument naming the bad name and listing the valid ones.
ImageChannels parse_channels(const std::string& names);

// A frame, `width` × `height` pixels, rows stored top to bottom. A plane is empty when absent: a rendered
// frame always has rgba, one read from an EXR file has whatever the file held.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<float> rgba;        // linear RGB, straight (not premultiplied) alpha; 4 per pixel
    std::vector<float> depth;       // eye-space depth along the view axis; +infinity where nothing was drawn
    std::vector<float> normals;     // unit normals, 3 per pixel; 0,0,0 for the background
    std::vector<float> level;       // HLOD level drawn at the pixel; -1 where no HLOD cube was drawn
    std::vector<uint32_t> node_id;  // the node drawn at the pixel; 0 for the background

    Image() = default;
    // Allocates the planes in `planes`, each filled with its background value (rgba: transparent black).
    Image(int width, int height, ImageChannels planes = ImageChannel::rgba);

    size_t pixel_count() const { return size_t(width) * size_t(height); }
    bool has(ImageChannel plane) const;
    ImageChannels planes() const;
    // Throws std::invalid_argument if the image has no pixels or a present plane's size is not
    // width × height × its values per pixel (a writer would read past its end).
    void check_sizes() const;
};

// OpenEXR's methods. none, rle, zips, zip and piz are lossless; pxr24 rounds FLOAT (Z) to 24 bits;
// b44 and b44a quantize every HALF channel, normals and level included; dwaa and dwab quantize R, G, B.
enum class ExrCompression { none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab };

// Parses a compression name as written on the command line and in Lua ("zip", "dwaa", ...;
// case-insensitive). Throws std::invalid_argument naming the bad name and listing the valid ones.
ExrCompression parse_exr_compression(const std::string& name);

struct ExrOptions {
    ExrCompression compression = ExrCompression::zip;
    // OpenEXR's worker threads for compression (Imf::setGlobalThreadCount: process-wide);
    // 0 leaves the current setting alone.
    int worker_threads = 0;
};

// Both writers write a temporary file beside `path` and rename it over `path` only when it is complete,
// so a crash or a full disk never leaves half a file under the real name. On failure they remove the
// temporary and throw std::runtime_error("cannot write <path>: <cause>"). An image with no pixels, or
// a plane whose size does not match width × height, is std::invalid_argument.

// 8-bit RGBA PNG: linear RGB through the sRGB transfer function, alpha linear; values clamped to
// [0, 1], NaN written as 0. Throws std::invalid_argument if the image has no rgba plane.
void write_png(const Image& image, const std::filesystem::path& path);
// Those 8-bit RGBA bytes, rows top to bottom (what write_png writes, for other writers).
std::vector<uint8_t> encode_srgb_rgba8(const Image& image);
// Pixels already encoded (a window's sRGB back buffer): width × height × 4 bytes, rows top to bottom.
void write_png_rgba8(const std::vector<uint8_t>& pixels, int width, int height, const std::filesystem::path& path);

// OpenEXR with the channels in `which`: R G B A (HALF), Z (FLOAT), N.X N.Y N.Z (HALF), level (HALF),
// id (UINT). Throws std::invalid_argument naming a channel asked for that the image does not hold.
void write_exr(const Image& image, const std::filesystem::path& path, ImageChannels which,
               const ExrOptions& options = {});

// Reads the channels above that the file holds (rgba when it has R, G and B; A defaults to 1) into
// float / uint planes. Throws std::runtime_error("cannot read <path>: <cause>").
Image read_exr(const std::filesystem::path& path);

}  // namespace strata
