// write_exr / read_exr: an Image's planes as OpenEXR channels (R G B A, Z, N.X N.Y N.Z, level, id).
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfThreading.h>
#include <half.h>

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "preprocess/atomic_file.h"
#include "engine/io/image.h"

namespace strata {
namespace {

// One EXR channel: its name and type in the file, and where its values live in an Image.
struct ExrChannel {
    const char* name;
    Imf::PixelType file_type;
    ImageChannel plane;
    int component;             // index within the plane's values of one pixel
    double missing_value = 0;  // what read_exr puts where a file lacks the channel
};

constexpr std::array<ExrChannel, 10> kExrChannels = {{
    {"R", Imf::HALF, ImageChannel::rgba, 0},
    {"G", Imf::HALF, ImageChannel::rgba, 1},
    {"B", Imf::HALF, ImageChannel::rgba, 2},
    {"A", Imf::HALF, ImageChannel::rgba, 3, 1.0},
    {"Z", Imf::FLOAT, ImageChannel::depth, 0},
    {"N.X", Imf::HALF, ImageChannel::normals, 0},
    {"N.Y", Imf::HALF, ImageChannel::normals, 1},
    {"N.Z", Imf::HALF, ImageChannel::normals, 2},
    {"level", Imf::HALF, ImageChannel::level, 0},
    {"id", Imf::UINT, ImageChannel::node_id, 0},
}};

Imf::Compression to_imf(ExrCompression compression) {
    switch (compression) {
        case ExrCompression::none: return Imf::NO_COMPRESSION;
        case ExrCompression::rle: return Imf::RLE_COMPRESSION;
        case ExrCompression::zips: return Imf::ZIPS_COMPRESSION;
        case ExrCompression::zip: return Imf::ZIP_COMPRESSION;
        case ExrCompression::piz: return Imf::PIZ_COMPRESSION;
        case ExrCompression::pxr24: return Imf::PXR24_COMPRESSION;
        case ExrCompression::b44: return Imf::B44_COMPRESSION;
        case ExrCompression::b44a: return Imf::B44A_COMPRESSION;
        case ExrCompression::dwaa: return Imf::DWAA_COMPRESSION;
        case ExrCompression::dwab: return Imf::DWAB_COMPRESSION;
    }
    throw std::invalid_argument("unknown EXR compression " + std::to_string(int(compression)));
}

const std::vector<float>& float_plane(const Image& image, ImageChannel plane) {
    switch (plane) {
        case ImageChannel::rgba: return image.rgba;
        case ImageChannel::depth: return image.depth;
        case ImageChannel::normals: return image.normals;
        case ImageChannel::level: return image.level;
        case ImageChannel::node_id: break;
    }
    throw std::logic_error("float_plane: " + channel_name(plane) + " is not a float plane");
}

// The channel's values inside a float or uint32 plane, as OpenEXR addresses them. Reading converts
// HALF to float by itself, so read_exr fills the image's planes directly.
Imf::Slice slice_of(const Image& image, const ExrChannel& channel, const Imath::Box2i& window) {
    if (channel.plane == ImageChannel::node_id)
        return Imf::Slice::Make(Imf::UINT, image.node_id.data(), window, sizeof(uint32_t));
    const size_t pixel_stride = values_per_pixel(channel.plane) * sizeof(float);
    return Imf::Slice::Make(Imf::FLOAT, float_plane(image, channel.plane).data() + channel.component, window,
                            pixel_stride, 0, 1, 1, channel.missing_value);
}

// Writing does not convert: a HALF channel needs its values as half in memory. The copy keeps the
// plane's interleaved layout, so the channel's slice addresses it like the float plane.
class HalfPlanes {
public:
    std::vector<half>& of(const Image& image, ImageChannel plane) {
        std::vector<half>& copy = copies_[size_t(plane)];
        const std::vector<float>& values = float_plane(image, plane);
        if (copy.empty()) copy.assign(values.begin(), values.end());
        return copy;
    }

private:
    std::array<std::vector<half>, 5> copies_;  // by ImageChannel
};

Imf::Slice output_slice_of(const Image& image, const ExrChannel& channel, const Imath::Box2i& window,
                           HalfPlanes& halves) {
    if (channel.file_type != Imf::HALF) return slice_of(image, channel, window);
    const size_t pixel_stride = values_per_pixel(channel.plane) * sizeof(half);
    return Imf::Slice::Make(Imf::HALF, halves.of(image, channel.plane).data() + channel.component, window,
                            pixel_stride);
}

void check_present(const Image& image, ImageChannels which) {
    if (which.empty()) throw std::invalid_argument("write_exr: no channels asked for");
    for (const ExrChannel& channel : kExrChannels)
        if (which.contains(channel.plane) && !image.has(channel.plane))
            throw std::invalid_argument("write_exr: channel " + channel_name(channel.plane) +
                                        " asked for, but the image has no such plane");
}

// OpenEXR's output stream over an AtomicOutputFile, which keeps the first failure for commit().
class ExrStream : public Imf::OStream {
public:
    ExrStream(AtomicOutputFile& file, const std::filesystem::path& path) : Imf::OStream(path.c_str()), file_(file) {}

    void write(const char data[], int size) override {
        file_.write(data, size_t(size));
        if (file_.failed()) throw std::runtime_error("write failed");  // the OStream contract: throw on I/O errors
    }
    uint64_t tellp() override { return file_.tell(); }
    void seekp(uint64_t offset) override { file_.seek(offset); }

private:
    AtomicOutputFile& file_;
};

}  // namespace

void write_exr(const Image& image, const std::filesystem::path& path, ImageChannels which, const ExrOptions& options) {
    image.check_sizes();
    check_present(image, which);
    if (options.worker_threads < 0) throw std::invalid_argument("write_exr: negative worker thread count");
    if (options.worker_threads > 0) Imf::setGlobalThreadCount(options.worker_threads);

    Imf::Header header(image.width, image.height);
    header.compression() = to_imf(options.compression);
    Imf::FrameBuffer frame;
    HalfPlanes halves;
    for (const ExrChannel& channel : kExrChannels) {
        if (!which.contains(channel.plane)) continue;
        header.channels().insert(channel.name, Imf::Channel(channel.file_type));
        frame.insert(channel.name, output_slice_of(image, channel, header.dataWindow(), halves));
    }

    AtomicOutputFile file(path);
    try {
        ExrStream stream(file, path);
        Imf::OutputFile output(stream, header);
        output.setFrameBuffer(frame);
        output.writePixels(image.height);
        // ~OutputFile writes the scan line offset table, so it must run before commit().
    } catch (const std::exception& e) {
        file.fail(e.what());
    }
    file.commit();
}

Image read_exr(const std::filesystem::path& path) {
    try {
        Imf::InputFile input(path.c_str());
        const Imath::Box2i window = input.header().dataWindow();
        const Imf::ChannelList& channels = input.header().channels();
        auto holds = [&](std::initializer_list<const char*> names) {
            for (const char* name : names)
                if (!channels.findChannel(name)) return false;
            return true;
        };
        ImageChannels planes;
        if (holds({"R", "G", "B"})) planes |= ImageChannel::rgba;
        if (holds({"Z"})) planes |= ImageChannel::depth;
        if (holds({"N.X", "N.Y", "N.Z"})) planes |= ImageChannel::normals;
        if (holds({"level"})) planes |= ImageChannel::level;
        if (holds({"id"})) planes |= ImageChannel::node_id;

        Image image(window.max.x - window.min.x + 1, window.max.y - window.min.y + 1, planes);
        Imf::FrameBuffer frame;
        for (const ExrChannel& channel : kExrChannels)
            if (planes.contains(channel.plane)) frame.insert(channel.name, slice_of(image, channel, window));
        input.setFrameBuffer(frame);
        input.readPixels(window.min.y, window.max.y);
        return image;
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read " + path.string() + ": " + e.what());
    }
}

}  // namespace strata
