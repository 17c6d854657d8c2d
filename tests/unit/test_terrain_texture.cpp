// A terrain's imagery (issue 17 §2): the BC1 codec and its mips, the texture section read back against
// the orthophoto's own pixels, a draped orthophoto rendered under ambient light alone as the
// orthophoto, and no pop where a textured cube switches to its children. The real data: Olinda's DEM
// and the Landsat 7 image of the same ground (bands 3, 2, 1: red, green, blue), from data/.
#include <gtest/gtest.h>

#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "engine/scene/cull_visitor.h"
#include "engine/scene/light.h"
#include "engine/scene/node.h"
#include "engine/stream/stream_cache.h"
#include "nodes/hlod_model.h"
#include "preprocess/cube_textures.h"
#include "preprocess/georeference.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/mesh.h"
#include "preprocess/terrain_build.h"
#include "tests/support/pop_check.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

const std::filesystem::path kData = std::filesystem::path(STRATA_SOURCE_DIR) / "data";

double linear_to_srgb(double c) { return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1 / 2.4) - 0.055; }

// An image's red, green and blue (by default the Landsat image's bands 3, 2, 1, in SIRGAS 2000 / UTM
// 25S), read with GDAL, sampled bilinearly at CRS positions (its pixel centres at whole pixels + ½).
class Orthophoto {
public:
    explicit Orthophoto(const std::filesystem::path& file = kData / "olinda_l7.tif", std::array<int, 3> bands = {3, 2, 1},
                        std::string crs = "EPSG:31985")
        : crs_(std::move(crs)) {
        GDALAllRegister();
        std::unique_ptr<GDALDataset> d(GDALDataset::Open(file.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
        if (!d) return;
        width_ = d->GetRasterXSize(), height_ = d->GetRasterYSize();
        d->GetGeoTransform(g_.data());
        rgb_.resize(size_t(width_) * height_ * 3);
        for (size_t c = 0; c < 3; ++c)
            EXPECT_EQ(d->GetRasterBand(bands[c])->RasterIO(GF_Read, 0, 0, width_, height_, rgb_.data() + c, width_, height_, GDT_Float32,
                                                           3 * sizeof(float), GSpacing(3 * sizeof(float)) * width_, nullptr),
                      CE_None);
    }
    bool loaded() const { return !rgb_.empty(); }
    const std::string& crs() const { return crs_; }
    // The colour at a CRS position, or nothing outside the image (a pixel's margin inside its edge).
    std::optional<std::array<double, 3>> at(double x, double y) const {
        const double u = (x - g_[0]) / g_[1] - 0.5, v = (y - g_[3]) / g_[5] - 0.5;
        if (!(u >= 0.5 && v >= 0.5 && u <= width_ - 1.5 && v <= height_ - 1.5)) return std::nullopt;
        const int a = int(u), b = int(v);
        const double fu = u - a, fv = v - b;
        std::array<double, 3> out{};
        for (int c = 0; c < 3; ++c) {
            auto px = [&](int dx, int dy) { return double(rgb_[(size_t(b + dy) * width_ + size_t(a + dx)) * 3 + size_t(c)]); };
            out[size_t(c)] = (px(0, 0) * (1 - fu) + px(1, 0) * fu) * (1 - fv) + (px(0, 1) * (1 - fu) + px(1, 1) * fu) * fv;
        }
        return out;
    }

private:
    std::string crs_;
    int width_ = 0, height_ = 0;
    std::array<double, 6> g_{};
    std::vector<float> rgb_;
};

class TerrainTexture : public ::testing::Test {
protected:
    void SetUp() override {
        if (!std::filesystem::exists(kData / "olinda_dem.tif") || !std::filesystem::exists(kData / "olinda_l7.tif"))
            GTEST_SKIP() << "data/olinda_dem.tif or olinda_l7.tif missing: run scripts/setup.sh";
    }
    // Olinda's terrain, cubes of 16 cells (4 levels), with the image draped.
    std::filesystem::path textured(uint32_t size = 0) {
        const std::filesystem::path out = dir_ / ("olinda_" + std::to_string(size) + ".hlod");
        if (!std::filesystem::exists(out)) {
            TerrainSettings settings;
            settings.cube_cells = 16;
            settings.texture = TextureSettings{kData / "olinda_l7.tif", {3, 2, 1}, size};
            build_terrain({kData / "olinda_dem.tif"}, out, settings, "olinda_dem.tif");
        }
        return out;
    }
    test::TempDir dir_;
};

TEST(Bc1, MipsAverageInLinearLightNotInSrgbBytes) {
    // A checkerboard of black and white texels: its half-size mip is the linear mean, 0.5, which sRGB
    // stores as 188 (averaging the bytes would give 128, visibly darker from afar).
    std::vector<uint8_t> rgb(8 * 8 * 3);
    for (uint32_t t = 0; t < 64; ++t) std::fill_n(&rgb[3 * t], 3, uint8_t((t % 8 + t / 8) % 2 ? 255 : 0));
    const std::vector<uint8_t> chain = encode_bc1_chain(rgb, 8);
    ASSERT_EQ(chain.size(), TextureLayout{.size = 8}.chain_bytes());
    ASSERT_EQ(TextureLayout{.size = 8}.mip_count(), 2u);
    const std::vector<uint8_t> mip1 = decode_bc1(std::span(chain).subspan(TextureLayout::bc1_bytes(8)), 4);
    for (uint8_t v : mip1) EXPECT_NEAR(int(v), 188, 3);
    // Mip 0 keeps the checkerboard: two colours, each exact in 5:6:5.
    const std::vector<uint8_t> mip0 = decode_bc1(std::span(chain).first(TextureLayout::bc1_bytes(8)), 8);
    for (size_t i = 0; i < mip0.size(); ++i) EXPECT_EQ(mip0[i], rgb[i]) << "byte " << i;
}

// Mean absolute difference, in 8-bit steps, between each cube's mip 0 and the image under its texels
// (every `stride`-th texel each way, of the cubes of levels up to `finest`); and the same with each
// texture upside down. In the ecef frame a texel shows the ground under its (x, y): the model point
// there at the height height_at gives.
struct TextureError {
    double mean = 0, flipped = 0;
    uint64_t texels = 0;
};

TextureError texture_error(const HlodModel& model, const Orthophoto& image, uint32_t stride = 1, uint32_t finest = kMaxHlodLevels) {
    const TextureLayout& layout = model.textures()->layout();
    const HlodHeader& h = model.header();
    const Georeference& geo = *model.georeference();
    double sum = 0, flipped = 0;
    uint64_t texels = 0;
    for (const HlodCube& cube : model.cubes()) {
        if (cube.node.level > finest) continue;
        EXPECT_EQ(cube.data->texture.size(), layout.chain_bytes());
        const std::vector<uint8_t> rgb = decode_bc1(std::span(cube.data->texture).first(TextureLayout::bc1_bytes(layout.size)), layout.size);
        const double s = h.cube_size(cube.node.level), span = 1 + 2 * double(layout.margin);
        for (uint32_t r = 0; r < layout.size; r += stride)
            for (uint32_t c = 0; c < layout.size; c += stride) {
                const double x = h.origin[0] + (cube.node.i - layout.margin + span * (c + 0.5) / layout.size) * s;
                const double y = h.origin[1] + (cube.node.j - layout.margin + span * (r + 0.5) / layout.size) * s;
                double z = 0;
                if (h.terrain->frame == uint32_t(TerrainFrameKind::ecef)) {
                    const std::optional<double> ground = model.height_at(x, y);
                    if (!ground) continue;
                    for (int round = 0; round < 4; ++round) z += *ground - geo.model_to_crs({x, y, z})[2];
                }
                const std::array<double, 3> crs = geo.to_geo({x, y, z}, image.crs());
                const auto expected = image.at(crs[0], crs[1]);
                if (!expected) continue;
                for (int ch = 0; ch < 3; ++ch) {
                    sum += std::abs(rgb[(size_t(r) * layout.size + c) * 3 + size_t(ch)] - (*expected)[size_t(ch)]);
                    flipped += std::abs(rgb[(size_t(layout.size - 1 - r) * layout.size + c) * 3 + size_t(ch)] - (*expected)[size_t(ch)]);
                }
                ++texels;
            }
    }
    return {sum / (3.0 * double(texels)), flipped / (3.0 * double(texels)), texels};
}

TEST_F(TerrainTexture, EveryCubesTextureIsTheOrthophotoOverItsFootprint) {
    const Orthophoto image;
    ASSERT_TRUE(image.loaded());
    auto model = HlodModel::load(textured());
    ASSERT_NE(model->textures(), nullptr);
    const TextureLayout& layout = model->textures()->layout();
    EXPECT_GE(layout.size, 32u);
    EXPECT_GT(layout.margin, 0.0f);  // the grid's cells overhang the octree's cells
    EXPECT_LT(layout.margin, 0.2f);
    const TextureError error = texture_error(*model, image);
    ASSERT_GT(error.texels, 100000u);
    EXPECT_LT(error.mean, 4.0) << "BC1 and resampling cost a few steps, no more";
    EXPECT_GT(error.flipped, 2.5 * error.mean) << "the control: the image upside down";
    EXPECT_NO_THROW(verify_hlod(HlodFile(textured())));
}

// The DEM warped to longitude and latitude, then built reprojected into the image's own CRS (SIRGAS
// 2000 / UTM 25S), or in the ecef frame (where the ground's height moves what a texel shows): drapes
// it as well either way.
TEST_F(TerrainTexture, ADemInDegreesReprojectedOrInEcefDrapesTheImageToo) {
    const Orthophoto image;
    ASSERT_TRUE(image.loaded());
    const std::filesystem::path degrees = dir_ / "olinda_degrees.tif";
    test::run_and_capture("gdalwarp -q -t_srs EPSG:4326 -r bilinear '" + (kData / "olinda_dem.tif").string() + "' '" + degrees.string() + "'");
    ASSERT_TRUE(std::filesystem::exists(degrees));
    TerrainSettings settings;
    settings.cube_cells = 16;
    settings.frame_crs = "EPSG:31985";
    settings.texture = TextureSettings{kData / "olinda_l7.tif", {3, 2, 1}, 0};
    build_terrain({degrees}, dir_ / "reprojected.hlod", settings, "olinda_degrees.tif");
    const auto model = HlodModel::load(dir_ / "reprojected.hlod");
    const TextureError error = texture_error(*model, image);
    ASSERT_GT(error.texels, 100000u);
    EXPECT_LT(error.mean, 4.0);
    EXPECT_GT(error.flipped, 2.5 * error.mean);
    settings.frame_crs.clear();
    settings.frame = TerrainFrameKind::ecef;
    build_terrain({degrees}, dir_ / "ecef.hlod", settings, "olinda_degrees.tif");
    const auto ecef = HlodModel::load(dir_ / "ecef.hlod");
    const TextureError curved = texture_error(*ecef, image, 2);
    ASSERT_GT(curved.texels, 20000u);
    EXPECT_LT(curved.mean, 4.0);
    EXPECT_GT(curved.flipped, 2.5 * curved.mean);
}

// A continent in the ecef frame: 12° × 12° of ground (101 × 101 samples, heights to 3 km) and an
// image of it whose colours change smoothly with longitude and latitude. Far from the tangent point
// the ground lies tens of kilometres below the plane: a texel must show the ground under its (x, y)
// (placed at the DEM's height there, not at its cube's middle, which for the root cube is hundreds of
// kilometres off and would shift the colours by half a degree).
TEST_F(TerrainTexture, OnAContinentInEcefEachTexelShowsTheGroundUnderIt) {
    const std::filesystem::path dem = dir_ / "continent.tif", picture = dir_ / "continent_image.tif";
    GDALAllRegister();
    GDALDriver* tiff = GetGDALDriverManager()->GetDriverByName("GTiff");
    OGRSpatialReference wgs84;
    wgs84.SetFromUserInput("EPSG:4326");
    {
        std::unique_ptr<GDALDataset> d(tiff->Create(dem.c_str(), 101, 101, 1, GDT_Float32, nullptr));
        double g[6] = {0, 0.12, 0, 50, 0, -0.12};
        d->SetGeoTransform(g), d->SetSpatialRef(&wgs84);
        std::vector<float> h(101 * 101);
        for (size_t s = 0; s < h.size(); ++s) h[s] = float(1500 + 1500 * std::sin(double(s % 101) * 0.1) * std::cos(double(s / 101) * 0.13));
        ASSERT_EQ(d->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, 101, 101, h.data(), 101, 101, GDT_Float32, 0, 0, nullptr), CE_None);
    }
    {
        constexpr int n = 601;
        std::unique_ptr<GDALDataset> d(tiff->Create(picture.c_str(), n, n, 3, GDT_Byte, nullptr));
        double g[6] = {0, 0.02, 0, 50, 0, -0.02};
        d->SetGeoTransform(g), d->SetSpatialRef(&wgs84);
        std::vector<uint8_t> rgb(size_t(n) * n * 3);
        for (int r = 0; r < n; ++r)
            for (int c = 0; c < n; ++c) {
                const double lon = 0.02 * (c + 0.5), lat = 50 - 0.02 * (r + 0.5);
                uint8_t* p = &rgb[(size_t(r) * n + size_t(c)) * 3];
                p[0] = uint8_t(128 + 100 * std::sin(lon * 1.3)), p[1] = uint8_t(128 + 100 * std::cos(lat * 1.7));
                p[2] = uint8_t(128 + 100 * std::sin((lon + lat) * 0.9));
            }
        ASSERT_EQ(d->RasterIO(GF_Write, 0, 0, n, n, rgb.data(), n, n, GDT_Byte, 3, nullptr, 3, GSpacing(3) * n, 1, nullptr), CE_None);
    }
    TerrainSettings settings;
    settings.cube_cells = 16;
    settings.frame = TerrainFrameKind::ecef;
    settings.texture = TextureSettings{picture, {}, 0};
    build_terrain({dem}, dir_ / "continent.hlod", settings, "continent.tif");
    const auto model = HlodModel::load(dir_ / "continent.hlod");
    const Orthophoto image(picture, {1, 2, 3}, "EPSG:4326");
    const TextureError error = texture_error(*model, image, 4);
    ASSERT_GT(error.texels, 10000u);
    EXPECT_LT(error.mean, 4.0) << "each texel the ground under it";
    EXPECT_GT(error.flipped, 2.5 * error.mean);
    const TextureError coarse = texture_error(*model, image, 2, 1);  // where a cube's middle is farthest from its ground
    ASSERT_GT(coarse.texels, 10000u);
    EXPECT_LT(coarse.mean, 4.0) << "the coarse levels' texels too";
}

TEST_F(TerrainTexture, ACorruptTextureIsNamedWhenItsCubeLoads) {
    const std::filesystem::path file = textured();
    const std::filesystem::path bad = dir_ / "bad.hlod";
    std::filesystem::copy_file(file, bad);
    HlodFile probe(bad);
    const HlodSection* section = probe.find_section(kTexturesTag);
    ASSERT_NE(section, nullptr);
    {
        std::fstream f(bad, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(std::streamoff(section->offset + section->size - 10));  // inside the last texture
        f.put(char(0x5a));
    }
    try {
        HlodModel::load(bad);
        FAIL() << "a corrupt texture loaded";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("bad.hlod: the texture of cube (level "), std::string::npos) << e.what();
    }
    EXPECT_THROW(verify_hlod(HlodFile(bad)), std::runtime_error);
}

TEST_F(TerrainTexture, AnImageThatIsNotAnImageOfTheGroundIsRefusedByName) {
    TerrainSettings settings;
    settings.cube_cells = 16;
    auto expect_error = [&](const TextureSettings& texture, const std::string& words) {
        settings.texture = texture;
        try {
            build_terrain({kData / "olinda_dem.tif"}, dir_ / "out.hlod", settings, "olinda_dem.tif");
            ADD_FAILURE() << "built with " << texture.image;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
        }
        EXPECT_FALSE(std::filesystem::exists(dir_ / "out.hlod"));
    };
    expect_error({dir_ / "missing.tif", {}, 0}, "missing.tif: no such file");
    expect_error({kData / "olinda_l7.tif", {7, 2, 1}, 0}, "olinda_l7.tif: has 6 bands, no band 7");
    expect_error({kData / "olinda_dem.tif", {}, 0}, "olinda_dem.tif: its samples are Float32");
    expect_error({kData / "olinda_l7.tif", {3, 2, 1}, 100}, "olinda_l7.tif: textures of 100 texels; a power of two from 8 to 4096");
    // The image of somewhere else: Trinidad's DEM, as bytes, lies an ocean away.
    const std::filesystem::path elsewhere = dir_ / "elsewhere.tif";
    test::run_and_capture("gdal_translate -q -ot Byte -scale -a_srs EPSG:4326 '" + (kData / "trinidad.nc").string() + "' '" + elsewhere.string() + "'");
    ASSERT_TRUE(std::filesystem::exists(elsewhere));
    expect_error({elsewhere, {}, 0}, "elsewhere.tif: the image does not overlap the terrain");
}

// A large image without overviews gets them for the build, in scratch files beside the output that go
// with it: the textures are those of the image itself.
TEST_F(TerrainTexture, ALargeImageIsReadThroughOverviewsMadeForTheBuild) {
    const std::filesystem::path wide = dir_ / "wide.tif", out_dir = dir_ / "out";
    std::filesystem::create_directories(out_dir);
    test::run_and_capture("gdal_translate -q -b 3 -b 2 -b 1 -outsize 5000 400 -r bilinear '" + (kData / "olinda_l7.tif").string() + "' '" + wide.string() + "'");
    ASSERT_TRUE(std::filesystem::exists(wide));
    TerrainSettings settings;
    settings.cube_cells = 16;
    settings.texture = TextureSettings{wide, {}, 32};
    std::vector<std::string> stages;
    Progress progress{.report = [&](std::string_view stage, double, double, std::string_view) {
        if (stages.empty() || stages.back() != stage) stages.emplace_back(stage);
    }};
    build_terrain({kData / "olinda_dem.tif"}, out_dir / "wide.hlod", settings, "olinda_dem.tif", progress);
    EXPECT_NE(std::find(stages.begin(), stages.end(), "image overviews"), stages.end());
    std::vector<std::string> left;
    for (const auto& entry : std::filesystem::directory_iterator(out_dir)) left.push_back(entry.path().filename().string());
    EXPECT_EQ(left, std::vector<std::string>{"wide.hlod"});
    EXPECT_NO_THROW(verify_hlod(HlodFile(out_dir / "wide.hlod")));
    // The root's texture, from the coarsest overview, against the one a build from the small image makes.
    const auto a = HlodModel::load(out_dir / "wide.hlod"), b = HlodModel::load(textured(32));
    const std::vector<uint8_t> wide_root = decode_bc1(std::span(a->cubes()[a->root()].data->texture).first(TextureLayout::bc1_bytes(32)), 32);
    const std::vector<uint8_t> root = decode_bc1(std::span(b->cubes()[b->root()].data->texture).first(TextureLayout::bc1_bytes(32)), 32);
    double sum = 0, flipped = 0;  // in 8-bit steps; the control: the root upside down
    for (size_t i = 0; i < root.size(); ++i) {
        sum += std::abs(int(wide_root[i]) - int(root[i]));
        const size_t row = i / (3 * 32), rest = i % (3 * 32);
        flipped += std::abs(int(wide_root[(31 - row) * 3 * 32 + rest]) - int(root[i]));
    }
    EXPECT_LT(sum / double(root.size()), 6.0) << "the stretched copy's resampling costs a few steps";
    EXPECT_GT(flipped, 2.5 * sum);
}

class TexturedRender : public TerrainTexture {
protected:
    static void SetUpTestSuite() { context_ = gl::create_headless_context(); }
    static void TearDownTestSuite() { context_.reset(); }
    static std::vector<float> render(Node& root, const Camera& camera) {
        gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
        Renderer renderer;
        renderer.render(root, camera, target);
        return target.read_color();
    }
    static inline std::unique_ptr<gl::Context> context_;
};

TEST_F(TexturedRender, UnderAmbientLightAloneTheDrapedImageRendersAsTheImage) {
    const Orthophoto image;
    ASSERT_TRUE(image.loaded());
    auto model = HlodModel::load(textured());
    auto root = std::make_shared<Group>();
    root->add(model);
    auto ambient = std::make_shared<AmbientLight>();
    ambient->color = {1, 1, 1};
    root->add(ambient);
    // Straight down on the middle half of the ground, north up.
    const Box box = model->bound();
    const glm::dvec3 centre = box.center();
    Camera camera;
    camera.width = camera.height = 256;
    camera.projection = ProjectionKind::orthographic;
    camera.ortho_height = 0.5 * (box.hi.y - box.lo.y);
    camera.look_at({centre.x, centre.y, box.hi.z + 1000}, {centre.x, centre.y, centre.z});
    const std::vector<float> pixels = render(*root, camera);
    const Georeference& geo = *model->georeference();
    double sum = 0, shifted = 0;
    uint64_t counted = 0;
    const double metres = camera.ortho_height / camera.height;
    for (int row = 0; row < camera.height; ++row)
        for (int column = 0; column < camera.width; ++column) {
            // Rows top (north) to bottom, as Framebuffer reads them.
            const double x = centre.x + (column + 0.5 - camera.width / 2.0) * metres, y = centre.y - (row + 0.5 - camera.height / 2.0) * metres;
            const std::array<double, 3> crs = geo.model_to_crs({x, y, 0});  // the node's frame is the model's
            const auto expected = image.at(crs[0], crs[1]);
            const auto away = image.at(crs[0] + 200, crs[1]);
            if (!expected || !away) continue;
            for (int c = 0; c < 3; ++c) {
                const double got = 255 * linear_to_srgb(std::clamp(double(pixels[(size_t(row) * camera.width + column) * 4 + size_t(c)]), 0.0, 1.0));
                sum += std::abs(got - (*expected)[size_t(c)]);
                shifted += std::abs(got - (*away)[size_t(c)]);
            }
            ++counted;
        }
    ASSERT_GT(counted, 30000u);
    EXPECT_LT(sum / (3.0 * counted), 4.0) << "the image's own colours, to BC1's and the resampling's few steps";
    EXPECT_GT(shifted, 2.5 * sum) << "the control: the image 200 m (7 pixels) east";
}

// Textures stream with their cubes, in the one budget: a streamed model's full-detail frame is the
// loaded model's, and what the cache holds counts every resident cube's texture twice (its bytes on
// the CPU and its layer on the GPU). Textures of 512² texels (15 MB in all) under a budget of 64 MiB
// fill two pages of texture layers (8 MiB each), so runs of cubes change pages, their parents' too.
TEST_F(TexturedRender, TexturesStreamWithTheirCubesInTheBudget) {
    const std::filesystem::path file = textured(512);
    StreamCache& cache = *StreamCache::shared();
    const uint64_t budget = cache.budget();
    cache.set_budget(uint64_t(64) << 20);
    struct Restore {
        StreamCache& cache;
        uint64_t budget;
        ~Restore() { cache.set_budget(budget); }
    } restore{cache, budget};
    auto frame = [](const std::shared_ptr<HlodModel>& model, FrameStats* stats) {
        model->set_pixel_error(1.0);
        auto root = std::make_shared<Group>();
        root->add(model);
        // One view for both, from the input's box (a model loaded whole bounds itself by its vertices, a
        // streamed one by that box grown by the lattice's rounding).
        const HlodHeader& h = model->header();
        const glm::dvec3 lo(h.bounds_lo[0], h.bounds_lo[1], h.bounds_lo[2]), hi(h.bounds_hi[0], h.bounds_hi[1], h.bounds_hi[2]);
        Camera camera;
        camera.width = camera.height = 160;
        camera.look_at((lo + hi) / 2.0 + glm::dvec3(0, -0.4, 0.5) * (hi.x - lo.x), (lo + hi) / 2.0);
        camera.near_clip = 100, camera.far_clip = 1e5;
        gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
        Renderer renderer;
        RenderSettings settings;
        settings.full_detail = true;
        const FrameStats s = renderer.render(*root, camera, target, settings);
        if (stats) *stats = s;
        return target.read_color();
    };
    const std::vector<float> reference = frame(HlodModel::load(file), nullptr);
    auto model = HlodModel::open(file);  // through the renderer's cache, StreamCache::shared()
    FrameStats stats;
    const auto got = frame(model, &stats);
    EXPECT_EQ(got, reference) << "the frame of the model loaded whole, bit for bit";
    model->sync_residency();
    uint64_t resident = 0;
    for (const HlodCube& cube : model->cubes())
        if (cube.data) {
            ++resident;
            EXPECT_EQ(cube.data->texture.size(), model->texture_bytes());
        }
    EXPECT_GT(resident, 0u);
    EXPECT_GT(resident, (uint64_t(8) << 20) / model->texture_bytes()) << "more cubes resident than a page of layers holds";
    EXPECT_GE(stats.memory_resident, resident * 2 * model->texture_bytes());
    EXPECT_LE(stats.memory_resident, cache.budget());
}

// The pop check (DESIGN.md §6) over a textured terrain: just before and just after a cube is replaced
// by its children the images agree, since the children's texels blend into the parent's with the
// morph's λ as their positions do; lit by ambient light alone, what shows is the imagery.
TEST_F(TexturedRender, NoPopWhenATexturedCubeIsReplacedByItsChildren) {
    auto model = HlodModel::load(textured());
    const double kappa0 = std::max(2.5, model->min_kappa0());
    model->set_kappa0(kappa0);
    const uint32_t chosen = test::busiest_cube(*model, model->header().max_level - 1);
    ASSERT_NE(chosen, kNoCube);
    auto root = std::make_shared<Group>();
    root->add(model);
    auto ambient = std::make_shared<AmbientLight>();
    ambient->color = {1, 1, 1};
    root->add(ambient);
    const test::PopFrames morphed = test::pop_frames(*root, *model, chosen, kappa0, true);
    ASSERT_TRUE(morphed.before_selected) << "just outside the switch distance the cube itself is drawn";
    ASSERT_FALSE(morphed.after_selected) << "just inside it its children are";
    EXPECT_LE(test::differing(morphed.before, morphed.after, 1.0f / 255), 0.001);
    // The control: without the morph (and its blend) the switch shows.
    const test::PopFrames plain = test::pop_frames(*root, *model, chosen, kappa0, false);
    EXPECT_GT(test::differing(plain.before, plain.after, 1.0f / 255), 0.01);
}

}  // namespace
}  // namespace strata
