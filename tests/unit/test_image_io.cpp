// Image output: EXR files read back with OpenEXR itself and with `exrheader`, PNG files read back with
// stb_image, channel names, and failures (missing directories, full disks) that leave nothing behind.
#include <ImfChannelList.h>
#include <ImfCompressionAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfThreading.h>
#include <half.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <stb_image.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "engine/io/image.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// ---- helpers --------------------------------------------------------------------------------------

// A 7×5 frame (not square, so a transposed file shows) whose every value says which pixel it is, with a
// background pixel in the top-left corner.
Image sample_image(ImageChannels planes = ImageChannels::all()) {
    Image image(7, 5, planes);
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const size_t i = size_t(y) * image.width + x;
            if (i == 0) continue;  // background: the planes keep the values the constructor filled in
            const float u = float(x) / image.width, v = float(y) / image.height;
            if (image.has(ImageChannel::rgba))
                for (int k = 0; k < 4; ++k) image.rgba[4 * i + k] = 0.1f + 0.2f * k + 0.1f * u - 0.05f * v;
            if (image.has(ImageChannel::depth)) image.depth[i] = 1.0f + 1000.0f * v + 3.1f * u;
            if (image.has(ImageChannel::normals)) {
                const float n[3] = {u - 0.5f, v - 0.5f, 1.0f};
                const float length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                for (int k = 0; k < 3; ++k) image.normals[3 * i + k] = n[k] / length;
            }
            if (image.has(ImageChannel::level)) image.level[i] = float(y);
            // Ids above 2^24, which a float cannot hold: they must travel as UINT all the way.
            if (image.has(ImageChannel::node_id)) image.node_id[i] = uint32_t(0x01000000u + 1000u * y + x);
        }
    return image;
}

// The sample frame without its sharp edges (the background corner, the level steps between rows): what
// lossy methods keep close, where B44 on a level step would be off by a whole level.
Image smooth_image() {
    Image image = sample_image();
    for (size_t k = 0; k < 4; ++k) image.rgba[k] = image.rgba[4 + k];
    image.depth[0] = image.depth[1];
    for (size_t k = 0; k < 3; ++k) image.normals[k] = image.normals[3 + k];
    std::fill(image.level.begin(), image.level.end(), 2.0f);
    image.node_id[0] = image.node_id[1];
    return image;
}

// A frame of random colours and depths: compresses badly, so it fills a small disk.
Image noise_image(int size) {
    Image image(size, size, {ImageChannel::rgba, ImageChannel::depth});
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (float& value : image.rgba) value = unit(rng);
    for (float& value : image.depth) value = unit(rng);
    return image;
}

// Rounds as a HALF channel stores the value.
float as_half(float value) { return float(half(value)); }

std::map<std::string, Imf::PixelType> channel_types(const Imf::Header& header) {
    std::map<std::string, Imf::PixelType> types;
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it) types[it.name()] = it.channel().type;
    return types;
}

// One channel of an EXR file read with OpenEXR directly: HALF and FLOAT channels as float, UINT as uint32.
template <class T>
std::vector<T> read_channel(const fs::path& path, const char* name) {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    const int width = window.max.x - window.min.x + 1, height = window.max.y - window.min.y + 1;
    std::vector<T> values(size_t(width) * height);
    Imf::FrameBuffer frame;
    const Imf::PixelType type = std::is_same_v<T, uint32_t> ? Imf::UINT : Imf::FLOAT;
    frame.insert(name, Imf::Slice::Make(type, values.data(), window, sizeof(T)));
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    return values;
}

// Plane `plane` component `k` of every pixel, in row order.
std::vector<float> component(const std::vector<float>& plane, size_t per_pixel, size_t k) {
    std::vector<float> values;
    for (size_t i = k; i < plane.size(); i += per_pixel) values.push_back(plane[i]);
    return values;
}

std::vector<float> halves(std::vector<float> values) {
    for (float& value : values) value = as_half(value);
    return values;
}

std::set<std::string> entries(const fs::path& dir) {
    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) names.insert(entry.path().filename().string());
    return names;
}

// The bytes of an 8-bit RGBA PNG as stb_image decodes them.
struct Png {
    int width = 0, height = 0, components = 0;
    std::vector<uint8_t> rgba;
};

Png read_png(const fs::path& path) {
    Png png;
    uint8_t* pixels = stbi_load(path.c_str(), &png.width, &png.height, &png.components, 4);
    if (!pixels) throw std::runtime_error(path.string() + ": " + stbi_failure_reason());
    png.rgba.assign(pixels, pixels + size_t(png.width) * png.height * 4);
    stbi_image_free(pixels);
    return png;
}

// ---- channel names --------------------------------------------------------------------------------

TEST(ImageChannels, ParsesNamesCaseInsensitively) {
    EXPECT_EQ(parse_channels("RGBA,Z,N,level,id"), ImageChannels::all());
    EXPECT_EQ(parse_channels("rgba, z"), (ImageChannels{ImageChannel::rgba, ImageChannel::depth}));
    EXPECT_EQ(parse_channels("LEVEL"), ImageChannels(ImageChannel::level));
    EXPECT_EQ(parse_channels("n,Id,n"), (ImageChannels{ImageChannel::normals, ImageChannel::node_id}));
}

TEST(ImageChannels, BadNameIsNamedWithTheValidOnes) {
    EXPECT_THAT([] { parse_channels("RGBA,depth"); },
                ThrowsMessage<std::invalid_argument>(
                    AllOf(HasSubstr("\"depth\""), HasSubstr("RGBA, Z, N, level, id"))));
    EXPECT_THROW(parse_channels(""), std::invalid_argument);
    EXPECT_THROW(parse_channels("RGBA,,Z"), std::invalid_argument);
}

TEST(ImageChannels, ParsesCompressionNames) {
    EXPECT_EQ(parse_exr_compression("zip"), ExrCompression::zip);
    EXPECT_EQ(parse_exr_compression("DWAA"), ExrCompression::dwaa);
    EXPECT_EQ(parse_exr_compression("none"), ExrCompression::none);
    EXPECT_THAT([] { parse_exr_compression("jpeg"); },
                ThrowsMessage<std::invalid_argument>(AllOf(HasSubstr("\"jpeg\""), HasSubstr("piz"))));
}

TEST(ImagePlanes, ConstructorFillsBackgroundValues) {
    Image image(3, 2, ImageChannels::all());
    EXPECT_EQ(image.pixel_count(), 6u);
    EXPECT_EQ(image.planes(), ImageChannels::all());
    EXPECT_EQ(image.rgba, std::vector<float>(24, 0.0f));
    EXPECT_EQ(image.depth, std::vector<float>(6, kInfinity));
    EXPECT_EQ(image.normals, std::vector<float>(18, 0.0f));
    EXPECT_EQ(image.level, std::vector<float>(6, -1.0f));
    EXPECT_EQ(image.node_id, std::vector<uint32_t>(6, 0));

    Image colour_only(3, 2);
    EXPECT_EQ(colour_only.planes(), ImageChannels(ImageChannel::rgba));
    EXPECT_FALSE(colour_only.has(ImageChannel::depth));
}

TEST(ImagePlanes, WrongPlaneSizeIsRefused) {
    test::TempDir dir;
    Image image(3, 2, {ImageChannel::rgba, ImageChannel::normals});
    image.normals.pop_back();
    EXPECT_THAT([&] { write_exr(image, dir / "bad.exr", ImageChannel::rgba); },
                ThrowsMessage<std::invalid_argument>(HasSubstr("plane N")));
    EXPECT_THROW(write_png(image, dir / "bad.png"), std::invalid_argument);
    EXPECT_THROW(write_png(Image(0, 0), dir / "empty.png"), std::invalid_argument);
    EXPECT_TRUE(entries(dir.path()).empty());
}

// ---- EXR ------------------------------------------------------------------------------------------

TEST(ExrOutput, EveryChannelRoundTripsThroughOpenExr) {
    test::TempDir dir;
    const Image image = sample_image();
    const fs::path path = dir / "frame.exr";
    write_exr(image, path, ImageChannels::all());

    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    EXPECT_EQ(window.min, Imath::V2i(0, 0));
    EXPECT_EQ(window.max, Imath::V2i(6, 4));
    EXPECT_EQ(file.header().lineOrder(), Imf::INCREASING_Y);  // the first row stored is the top row
    EXPECT_EQ(file.header().compression(), Imf::ZIP_COMPRESSION);
    const std::map<std::string, Imf::PixelType> expected_types = {
        {"R", Imf::HALF},   {"G", Imf::HALF},   {"B", Imf::HALF},     {"A", Imf::HALF},  {"Z", Imf::FLOAT},
        {"N.X", Imf::HALF}, {"N.Y", Imf::HALF}, {"N.Z", Imf::HALF}, {"level", Imf::HALF}, {"id", Imf::UINT}};
    EXPECT_EQ(channel_types(file.header()), expected_types);

    const char* rgba[] = {"R", "G", "B", "A"};
    for (size_t k = 0; k < 4; ++k)
        EXPECT_EQ(read_channel<float>(path, rgba[k]), halves(component(image.rgba, 4, k))) << rgba[k];
    EXPECT_EQ(read_channel<float>(path, "Z"), image.depth);  // FLOAT: exact, +infinity included
    const char* normals[] = {"N.X", "N.Y", "N.Z"};
    for (size_t k = 0; k < 3; ++k)
        EXPECT_EQ(read_channel<float>(path, normals[k]), halves(component(image.normals, 3, k))) << normals[k];
    EXPECT_EQ(read_channel<float>(path, "level"), image.level);  // small integers: exact in half
    EXPECT_EQ(read_channel<uint32_t>(path, "id"), image.node_id);

    // Spot checks against the layout, independent of the helpers above.
    const std::vector<float> z = read_channel<float>(path, "Z");
    EXPECT_EQ(z[0], kInfinity);                            // background, top-left
    EXPECT_FLOAT_EQ(z[7 * 4 + 0], 1.0f + 1000.0f * 0.8f);  // bottom row, left
    EXPECT_EQ(read_channel<uint32_t>(path, "id")[7 * 2 + 3], 0x01000000u + 2003u);
    EXPECT_EQ(read_channel<float>(path, "level")[0], -1.0f);
}

TEST(ExrOutput, SubsetHoldsOnlyTheChannelsAskedFor) {
    test::TempDir dir;
    const fs::path path = dir / "subset.exr";
    write_exr(sample_image(), path, {ImageChannel::rgba, ImageChannel::depth});
    const std::map<std::string, Imf::PixelType> expected_types = {
        {"R", Imf::HALF}, {"G", Imf::HALF}, {"B", Imf::HALF}, {"A", Imf::HALF}, {"Z", Imf::FLOAT}};
    EXPECT_EQ(channel_types(Imf::InputFile(path.c_str()).header()), expected_types);

    write_exr(sample_image({ImageChannel::node_id}), path, ImageChannel::node_id);
    EXPECT_EQ(channel_types(Imf::InputFile(path.c_str()).header()),
              (std::map<std::string, Imf::PixelType>{{"id", Imf::UINT}}));
}

TEST(ExrOutput, ReadExrGivesBackWhatWasWritten) {
    test::TempDir dir;
    const Image image = sample_image();
    write_exr(image, dir / "all.exr", ImageChannels::all());
    const Image back = read_exr(dir / "all.exr");
    EXPECT_EQ(back.width, 7);
    EXPECT_EQ(back.height, 5);
    EXPECT_EQ(back.planes(), ImageChannels::all());
    EXPECT_EQ(back.rgba, halves(image.rgba));
    EXPECT_EQ(back.depth, image.depth);
    EXPECT_EQ(back.normals, halves(image.normals));
    EXPECT_EQ(back.level, image.level);
    EXPECT_EQ(back.node_id, image.node_id);

    write_exr(image, dir / "depth.exr", {ImageChannel::depth, ImageChannel::level});
    const Image depth_only = read_exr(dir / "depth.exr");
    EXPECT_EQ(depth_only.planes(), (ImageChannels{ImageChannel::depth, ImageChannel::level}));
    EXPECT_EQ(depth_only.depth, image.depth);
}

TEST(ExrOutput, ReadExrNamesAFileItCannotRead) {
    test::TempDir dir;
    std::ofstream(dir / "junk.exr") << "not an image";
    EXPECT_THAT([&] { read_exr(dir / "junk.exr"); },
                ThrowsMessage<std::runtime_error>(HasSubstr("cannot read " + (dir / "junk.exr").string())));
    EXPECT_THROW(read_exr(dir / "missing.exr"), std::runtime_error);
}

struct CompressionCase {
    const char* name;
    ExrCompression compression;
    Imf::Compression imf;
    // Lossy methods: error allowed on HALF channels. B44 quantizes all of them in 4×4 blocks and handles
    // signed values (normals) worst; DWA quantizes only R, G, B.
    float half_tolerance;
    bool lossy_float;      // PXR24 keeps 24 bits of FLOAT channels
};

void PrintTo(const CompressionCase& c, std::ostream* out) { *out << c.name; }

class ExrCompressionTest : public ::testing::TestWithParam<CompressionCase> {};

TEST_P(ExrCompressionTest, RoundTrips) {
    const CompressionCase c = GetParam();
    test::TempDir dir;
    const Image image = c.half_tolerance > 0 ? smooth_image() : sample_image();
    const fs::path path = dir / "compressed.exr";
    write_exr(image, path, ImageChannels::all(), {.compression = c.compression});

    EXPECT_EQ(Imf::InputFile(path.c_str()).header().compression(), c.imf);
    const Image back = read_exr(path);
    ASSERT_EQ(back.planes(), ImageChannels::all());
    auto expect_near = [&](const std::vector<float>& got, const std::vector<float>& want, float tolerance) {
        ASSERT_EQ(got.size(), want.size());
        for (size_t i = 0; i < got.size(); ++i) EXPECT_NEAR(got[i], want[i], tolerance) << "value " << i;
    };
    expect_near(back.rgba, halves(image.rgba), c.half_tolerance);
    expect_near(back.normals, halves(image.normals), c.half_tolerance);
    expect_near(back.level, image.level, c.half_tolerance);
    if (c.lossy_float) {
        for (size_t i = 1; i < image.depth.size(); ++i)
            EXPECT_NEAR(back.depth[i], image.depth[i], image.depth[i] * 1e-4f) << "depth " << i;
        EXPECT_EQ(back.depth[0], image.depth[0]);  // +infinity stays infinite
    } else {
        EXPECT_EQ(back.depth, image.depth);
    }
    EXPECT_EQ(back.node_id, image.node_id);  // UINT is lossless under every method
}

INSTANTIATE_TEST_SUITE_P(
    EveryMethod, ExrCompressionTest,
    ::testing::Values(CompressionCase{"none", ExrCompression::none, Imf::NO_COMPRESSION, 0, false},
                      CompressionCase{"rle", ExrCompression::rle, Imf::RLE_COMPRESSION, 0, false},
                      CompressionCase{"zips", ExrCompression::zips, Imf::ZIPS_COMPRESSION, 0, false},
                      CompressionCase{"zip", ExrCompression::zip, Imf::ZIP_COMPRESSION, 0, false},
                      CompressionCase{"piz", ExrCompression::piz, Imf::PIZ_COMPRESSION, 0, false},
                      CompressionCase{"pxr24", ExrCompression::pxr24, Imf::PXR24_COMPRESSION, 0, true},
                      CompressionCase{"b44", ExrCompression::b44, Imf::B44_COMPRESSION, 0.1f, false},
                      CompressionCase{"b44a", ExrCompression::b44a, Imf::B44A_COMPRESSION, 0.1f, false},
                      CompressionCase{"dwaa", ExrCompression::dwaa, Imf::DWAA_COMPRESSION, 0.02f, false},
                      CompressionCase{"dwab", ExrCompression::dwab, Imf::DWAB_COMPRESSION, 0.02f, false}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(ExrOutput, WorkerThreadsOptionSetsOpenExrThreadCount) {
    test::TempDir dir;
    const Image image = noise_image(64);
    write_exr(image, dir / "threaded.exr", {ImageChannel::rgba, ImageChannel::depth}, {.worker_threads = 2});
    EXPECT_EQ(Imf::globalThreadCount(), 2);
    write_exr(image, dir / "same.exr", {ImageChannel::rgba, ImageChannel::depth});  // 0: left as it is
    EXPECT_EQ(Imf::globalThreadCount(), 2);
    EXPECT_EQ(read_exr(dir / "threaded.exr").depth, image.depth);
    Imf::setGlobalThreadCount(0);
}

TEST(ExrOutput, ExrheaderListsTheChannels) {
    if (std::system("command -v exrheader >/dev/null 2>&1") != 0) GTEST_SKIP() << "exrheader is not installed";
    test::TempDir dir;
    const fs::path path = dir / "listed.exr";
    write_exr(sample_image(), path, ImageChannels::all(), {.compression = ExrCompression::piz});
    const std::string output = test::run_and_capture("exrheader '" + path.string() + "' 2>&1");
    for (const char* name : {"R", "G", "B", "A", "N.X", "N.Y", "N.Z"})
        EXPECT_THAT(output, HasSubstr(std::string(name) + ", 16-bit floating-point")) << output;
    EXPECT_THAT(output, HasSubstr("Z, 32-bit floating-point")) << output;
    EXPECT_THAT(output, HasSubstr("level, 16-bit floating-point")) << output;
    EXPECT_THAT(output, HasSubstr("id, 32-bit unsigned integer")) << output;
    EXPECT_THAT(output, HasSubstr("piz")) << output;
    EXPECT_THAT(output, HasSubstr("(0 0) - (6 4)")) << output;
}

TEST(ExrOutput, MissingPlaneIsNamed) {
    test::TempDir dir;
    const Image image = sample_image({ImageChannel::rgba, ImageChannel::depth});
    EXPECT_THAT([&] { write_exr(image, dir / "x.exr", {ImageChannel::rgba, ImageChannel::normals}); },
                ThrowsMessage<std::invalid_argument>(HasSubstr("channel N")));
    EXPECT_THAT([&] { write_exr(image, dir / "x.exr", ImageChannel::node_id); },
                ThrowsMessage<std::invalid_argument>(HasSubstr("channel id")));
    EXPECT_THROW(write_exr(image, dir / "x.exr", ImageChannels{}), std::invalid_argument);
    EXPECT_TRUE(entries(dir.path()).empty());
}

// ---- PNG ------------------------------------------------------------------------------------------

TEST(PngOutput, EncodesLinearColourAsSrgb) {
    test::TempDir dir;
    // Linear value → the sRGB byte (IEC 61966-2-1, rounded to nearest). 0.0031308 is where the linear
    // segment meets the power curve; 0.002 lies on the linear segment, 0.004 on the curve.
    const std::vector<std::pair<float, int>> expected = {{0.0f, 0},   {1.0f, 255},       {0.5f, 188},
                                                         {0.18f, 118}, {0.0031308f, 10}, {0.002f, 7},
                                                         {0.004f, 13}, {0.2158605f, 128}};
    Image image(int(expected.size()), 1);
    for (size_t i = 0; i < expected.size(); ++i) {
        for (int k = 0; k < 3; ++k) image.rgba[4 * i + k] = expected[i].first;
        image.rgba[4 * i + 3] = 1.0f;
    }
    write_png(image, dir / "ramp.png");
    const Png png = read_png(dir / "ramp.png");
    EXPECT_EQ(png.components, 4);
    ASSERT_EQ(png.width, int(expected.size()));
    ASSERT_EQ(png.height, 1);
    for (size_t i = 0; i < expected.size(); ++i)
        for (int k = 0; k < 3; ++k)
            EXPECT_EQ(png.rgba[4 * i + k], expected[i].second) << "linear " << expected[i].first;
}

TEST(PngOutput, AlphaIsLinearAndOutOfRangeValuesAreClamped) {
    test::TempDir dir;
    Image image(4, 2);
    // Top row: alpha ramp with plain colours. Bottom row: NaN, negative, above one, infinity.
    const float top[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0.5f}, {0, 0, 1, 0.25f}, {1, 1, 1, 1}};
    const float bottom[4][4] = {{kNaN, kNaN, kNaN, kNaN}, {-1, -0.5f, -kInfinity, -3}, {2, 7, kInfinity, 4},
                                {0.5f, kNaN, 3, kNaN}};
    for (int x = 0; x < 4; ++x)
        for (int k = 0; k < 4; ++k) {
            image.rgba[4 * x + k] = top[x][k];
            image.rgba[4 * (4 + x) + k] = bottom[x][k];
        }
    write_png(image, dir / "alpha.png");
    const Png png = read_png(dir / "alpha.png");
    ASSERT_EQ(png.width, 4);
    ASSERT_EQ(png.height, 2);
    const std::vector<uint8_t> expected = {255, 0, 0, 0,   0, 255, 0, 128,     0, 0, 255, 64,   255, 255, 255, 255,
                                           0, 0, 0, 0,     0, 0, 0, 0,         255, 255, 255, 255, 188, 0, 255, 0};
    EXPECT_EQ(png.rgba, expected);
}

TEST(PngOutput, ReplacesAnExistingFile) {
    test::TempDir dir;
    std::ofstream(dir / "frame.png") << "old contents";
    Image image(2, 2);
    write_png(image, dir / "frame.png");
    EXPECT_EQ(read_png(dir / "frame.png").width, 2);
    EXPECT_EQ(entries(dir.path()), std::set<std::string>{"frame.png"});
}

// ---- failures -------------------------------------------------------------------------------------

using Writer = std::function<void(const Image&, const fs::path&)>;

// Each format's writer, by file extension; EXR writes every plane the image has.
const std::vector<std::pair<std::string, Writer>>& writers() {
    static const std::vector<std::pair<std::string, Writer>> all = {
        {"png", [](const Image& image, const fs::path& path) { write_png(image, path); }},
        {"exr", [](const Image& image, const fs::path& path) { write_exr(image, path, image.planes()); }},
    };
    return all;
}

TEST(ImageOutputFailure, UnwritablePathIsNamedAndLeavesNothing) {
    const Image image = sample_image();
    for (const auto& [format, write] : writers()) {
        SCOPED_TRACE(format);
        test::TempDir dir;
        std::ofstream(dir / "file.txt") << "a regular file, not a directory";
        const fs::path missing_dir = dir / "no" / ("such." + format);
        EXPECT_THAT([&] { write(image, missing_dir); },
                    ThrowsMessage<std::runtime_error>(AllOf(HasSubstr("cannot write " + missing_dir.string()),
                                                            HasSubstr("No such file or directory"))));
        // Fails even for root, who ignores permissions.
        const fs::path under_file = dir / "file.txt" / ("x." + format);
        EXPECT_THAT([&] { write(image, under_file); },
                    ThrowsMessage<std::runtime_error>(AllOf(HasSubstr("cannot write " + under_file.string()),
                                                            HasSubstr("Not a directory"))));
        // The target is a directory: the temporary is written, the rename fails and the temporary goes.
        const fs::path taken = dir / ("taken." + format);
        fs::create_directory(taken);
        EXPECT_THAT([&] { write(image, taken); },
                    ThrowsMessage<std::runtime_error>(HasSubstr("cannot write " + taken.string())));
        EXPECT_EQ(entries(dir.path()), (std::set<std::string>{"file.txt", "taken." + format}));
    }
}

TEST(ImageOutputFailure, ReadOnlyDirectoryIsNamedAndLeavesNothing) {
    if (::geteuid() == 0) GTEST_SKIP() << "root ignores directory permissions";
    const Image image = sample_image();
    for (const auto& [format, write] : writers()) {
        SCOPED_TRACE(format);
        test::TempDir dir;
        fs::create_directory(dir / "locked");
        fs::permissions(dir / "locked", fs::perms::owner_read | fs::perms::owner_exec);
        const fs::path target = dir / "locked" / ("x." + format);
        EXPECT_THAT([&] { write(image, target); },
                    ThrowsMessage<std::runtime_error>(AllOf(HasSubstr("cannot write " + target.string()),
                                                            HasSubstr("Permission denied"))));
        EXPECT_TRUE(entries(dir / "locked").empty());
        fs::permissions(dir / "locked", fs::perms::owner_all);
    }
}

// Runs `body` in a child process with a 64 KiB tmpfs mounted on `dir`, in user and mount namespaces of
// its own (so no privileges are needed and the parent never sees the mount). Returns the child's
// report: "" when `body` found everything as expected, "skip: ..." when the namespaces or the mount are
// not allowed here, otherwise what went wrong.
std::string on_tiny_filesystem(const fs::path& dir, const std::function<std::string()>& body) {
    int report[2];
    if (::pipe(report) != 0) return "pipe failed";
    const uid_t uid = ::getuid();
    const gid_t gid = ::getgid();
    const pid_t child = ::fork();
    if (child == 0) {
        ::close(report[0]);
        auto finish = [&](const std::string& message) {
            (void)!::write(report[1], message.data(), message.size());
            ::_exit(0);
        };
        auto write_file = [](const char* path, const std::string& text) {
            std::ofstream file(path);
            file << text;
            file.flush();
            return bool(file);
        };
        if (::unshare(CLONE_NEWUSER | CLONE_NEWNS) == 0) {
            write_file("/proc/self/setgroups", "deny");
            if (!write_file("/proc/self/uid_map", "0 " + std::to_string(uid) + " 1") ||
                !write_file("/proc/self/gid_map", "0 " + std::to_string(gid) + " 1"))
                finish("skip: cannot map ids in a user namespace");
        } else if (::unshare(CLONE_NEWNS) != 0) {
            finish("skip: no user or mount namespaces here");
        }
        if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
            ::mount("strata-test", dir.c_str(), "tmpfs", 0, "size=64k") != 0)
            finish(std::string("skip: cannot mount a tmpfs: ") + std::strerror(errno));
        try {
            finish(body());
        } catch (const std::exception& e) {
            finish(std::string("unexpected exception: ") + e.what());
        }
    }
    ::close(report[1]);
    std::string message;
    char buffer[512];
    for (ssize_t n; (n = ::read(report[0], buffer, sizeof buffer)) > 0;) message.append(buffer, size_t(n));
    ::close(report[0]);
    int status = 0;
    ::waitpid(child, &status, 0);
    if (!WIFEXITED(status)) return "the child process died";
    return message;
}

TEST(ImageOutputFailure, FullDiskLeavesTheOldFileAndNoTemporary) {
    // Megabytes of incompressible pixels: more than the stdio buffer, so writes fail midway, not at the end.
    const Image big = noise_image(512);
    for (const auto& [format, write] : writers()) {
        SCOPED_TRACE(format);
        test::TempDir dir;
        const fs::path disk = dir / "disk";
        fs::create_directory(disk);
        const std::string name = "frame." + format;
        const std::string report = on_tiny_filesystem(disk, [&]() -> std::string {
            std::ofstream(disk / name) << "previous frame";
            try {
                write(big, disk / name);
                return "no error on a full disk";
            } catch (const std::runtime_error& e) {
                const std::string what = e.what();
                if (what.find("cannot write " + (disk / name).string()) == std::string::npos ||
                    what.find("No space left on device") == std::string::npos)
                    return "unexpected message: " + what;
            }
            if (entries(disk) != std::set<std::string>{name}) return "a temporary was left behind";
            std::ifstream old(disk / name);
            const std::string contents{std::istreambuf_iterator<char>(old), {}};
            return contents == "previous frame" ? "" : "the previous file was changed";
        });
        if (report.rfind("skip:", 0) == 0) GTEST_SKIP() << report;
        EXPECT_EQ(report, "");
    }
}

}  // namespace
}  // namespace strata
