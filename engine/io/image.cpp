// strata::Image, its planes, and the channel and compression names used on the command line and in Lua.
#include "engine/io/image.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <utility>

namespace strata {
namespace {

constexpr std::array<ImageChannel, 5> kChannels = {ImageChannel::rgba, ImageChannel::depth, ImageChannel::normals,
                                                   ImageChannel::level, ImageChannel::node_id};

constexpr std::array<std::pair<ExrCompression, std::string_view>, 10> kCompressionNames = {{
    {ExrCompression::none, "none"},
    {ExrCompression::rle, "rle"},
    {ExrCompression::zips, "zips"},
    {ExrCompression::zip, "zip"},
    {ExrCompression::piz, "piz"},
    {ExrCompression::pxr24, "pxr24"},
    {ExrCompression::b44, "b44"},
    {ExrCompression::b44a, "b44a"},
    {ExrCompression::dwaa, "dwaa"},
    {ExrCompression::dwab, "dwab"},
}};

bool equal_ignoring_case(std::string_view a, std::string_view b) {
    auto same = [](unsigned char x, unsigned char y) { return std::tolower(x) == std::tolower(y); };
    return std::ranges::equal(a, b, same);
}

std::string_view trim(std::string_view text) {
    auto blank = [](unsigned char c) { return std::isspace(c) != 0; };
    while (!text.empty() && blank(text.front())) text.remove_prefix(1);
    while (!text.empty() && blank(text.back())) text.remove_suffix(1);
    return text;
}

ImageChannel parse_channel(std::string_view name) {
    for (ImageChannel channel : kChannels)
        if (equal_ignoring_case(name, channel_name(channel))) return channel;
    std::string valid;
    for (ImageChannel channel : kChannels) valid += (valid.empty() ? "" : ", ") + channel_name(channel);
    throw std::invalid_argument("unknown image channel \"" + std::string(name) + "\" (valid: " + valid + ")");
}

size_t plane_size(const Image& image, ImageChannel plane) {
    switch (plane) {
        case ImageChannel::rgba: return image.rgba.size();
        case ImageChannel::depth: return image.depth.size();
        case ImageChannel::normals: return image.normals.size();
        case ImageChannel::level: return image.level.size();
        case ImageChannel::node_id: return image.node_id.size();
    }
    return 0;
}

}  // namespace

std::string channel_name(ImageChannel channel) {
    switch (channel) {
        case ImageChannel::rgba: return "RGBA";
        case ImageChannel::depth: return "Z";
        case ImageChannel::normals: return "N";
        case ImageChannel::level: return "level";
        case ImageChannel::node_id: return "id";
    }
    return "?";
}

size_t values_per_pixel(ImageChannel plane) {
    switch (plane) {
        case ImageChannel::rgba: return 4;
        case ImageChannel::normals: return 3;
        case ImageChannel::depth:
        case ImageChannel::level:
        case ImageChannel::node_id: return 1;
    }
    return 0;
}

ImageChannels parse_channels(const std::string& names) {
    ImageChannels channels;
    std::string_view rest = names;
    while (true) {
        size_t comma = rest.find(',');
        channels |= parse_channel(trim(rest.substr(0, comma)));
        if (comma == std::string_view::npos) return channels;
        rest.remove_prefix(comma + 1);
    }
}

ExrCompression parse_exr_compression(const std::string& name) {
    for (auto [compression, known] : kCompressionNames)
        if (equal_ignoring_case(trim(name), known)) return compression;
    std::string valid;
    for (auto [compression, known] : kCompressionNames) valid += (valid.empty() ? "" : ", ") + std::string(known);
    throw std::invalid_argument("unknown EXR compression \"" + name + "\" (valid: " + valid + ")");
}

Image::Image(int width, int height, ImageChannels planes) : width(width), height(height) {
    if (width < 0 || height < 0) throw std::invalid_argument("negative image size");
    const size_t n = pixel_count();
    if (planes.contains(ImageChannel::rgba)) rgba.assign(4 * n, 0.0f);
    if (planes.contains(ImageChannel::depth)) depth.assign(n, std::numeric_limits<float>::infinity());
    if (planes.contains(ImageChannel::normals)) normals.assign(3 * n, 0.0f);
    if (planes.contains(ImageChannel::level)) level.assign(n, -1.0f);
    if (planes.contains(ImageChannel::node_id)) node_id.assign(n, 0);
}

bool Image::has(ImageChannel plane) const { return plane_size(*this, plane) != 0; }

ImageChannels Image::planes() const {
    ImageChannels present;
    for (ImageChannel plane : kChannels)
        if (has(plane)) present |= plane;
    return present;
}

void Image::check_sizes() const {
    if (width <= 0 || height <= 0)
        throw std::invalid_argument("image of " + std::to_string(width) + "x" + std::to_string(height) +
                                    " pixels: nothing to write");
    for (ImageChannel plane : kChannels) {
        const size_t size = plane_size(*this, plane), expected = values_per_pixel(plane) * pixel_count();
        if (size != 0 && size != expected)
            throw std::invalid_argument("image plane " + channel_name(plane) + " holds " + std::to_string(size) +
                                        " values, a " + std::to_string(width) + "x" + std::to_string(height) +
                                        " image needs " + std::to_string(expected));
    }
}

}  // namespace strata
