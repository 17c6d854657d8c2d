// The real terrain reader (tests/support/dem_grid.h) on data/trinidad.nc, NCL's 3 arc-second DEM of
// southern Colorado that scripts/setup.sh fetches. The expected values were read independently of it,
// with numpy from the file's bytes and with ncdump: rows run south to north from 37°N, columns west to
// east from 106°W, elevations in feet (no units attribute); the highest sample is Blanca Peak's.
#include "tests/support/dem_grid.h"

#include "tests/support/test_meshes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <iterator>
#include <numbers>
#include <string>

namespace strata::test {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr size_t kRows = 1201, kColumns = 2401;
constexpr double kFoot = 0.3048;

class DemGrid : public ::testing::Test {
protected:
    void SetUp() override {
        if (!std::filesystem::exists(dem_)) GTEST_SKIP() << dem_ << " is missing: run scripts/setup.sh to fetch it";
    }

    // The window around Blanca Peak: 25 rows from 680, 40 columns from 600; the peak is sample (692, 617).
    static DemWindow blanca(size_t stride = 1) { return {.first_column = 600, .first_row = 680, .columns = 40, .rows = 25, .stride = stride}; }
    static DemOptions feet() { return {.variable = "", .unit = ElevationUnit::feet}; }

    static const float* vertex(const Mesh& mesh, size_t width, size_t row, size_t column) {
        return &mesh.positions[3 * (row * width + column)];
    }

    // A copy of the DEM's first `length` bytes (all by default), changed by `edit`, in the test's folder.
    std::filesystem::path copy(const std::string& name, const std::function<void(std::string&)>& edit,
                               size_t length = std::string::npos) const {
        std::ifstream in(dem_, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        bytes.resize(std::min(length, bytes.size()));
        edit(bytes);
        const std::filesystem::path path = dir_ / name;
        std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
        return path;
    }

    static void expect_error(const std::filesystem::path& path, const std::string& detail, const DemWindow& window = {},
                             const DemOptions& options = {}) {
        try {
            read_dem_grid(path, window, options);
            ADD_FAILURE() << "no InputError for " << path;
        } catch (const InputError& e) {
            EXPECT_THAT(e.what(), StartsWith(path.string() + ": "));
            EXPECT_THAT(e.what(), HasSubstr(detail));
        }
    }

    const std::filesystem::path dem_ = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "trinidad.nc";
    TempDir dir_;
};

TEST_F(DemGrid, WholeGridSpansTheFileAndItsElevations) {
    const Mesh mesh = read_dem_grid(dem_, {}, feet());
    EXPECT_EQ(mesh.vertex_count(), kRows * kColumns);
    EXPECT_EQ(mesh.triangle_count(), 2 * (kRows - 1) * (kColumns - 1));
    float low[3], high[3];
    for (int k = 0; k < 3; ++k) low[k] = high[k] = mesh.positions[k];
    for (size_t v = 0; v < mesh.vertex_count(); ++v)
        for (int k = 0; k < 3; ++k)
            low[k] = std::min(low[k], mesh.positions[3 * v + k]), high[k] = std::max(high[k], mesh.positions[3 * v + k]);
    // The lowest sample (4457.52 ft, in the Arkansas valley) and the highest (14176.16 ft, Blanca Peak);
    // the file's own minmax_elevW/E say 1359 and 4322 m.
    EXPECT_NEAR(low[2], 4457.52 * kFoot, 1e-3);
    EXPECT_NEAR(high[2], 14176.16 * kFoot, 1e-3);
    EXPECT_NEAR(low[2], 1359, 1);
    EXPECT_NEAR(high[2], 4322, 2);
    // 2° of longitude at 37.5°N and 1° of latitude, from the south-west corner; on WGS84 they are
    // 176.85 km and 110.99 km, which the spherical figures meet to 0.4 %.
    EXPECT_EQ(low[0], 0.0f);
    EXPECT_EQ(low[1], 0.0f);
    EXPECT_NEAR(high[0], 2 * std::cos(37.5 * std::numbers::pi / 180) * 111320, 0.01);
    EXPECT_NEAR(high[1], 110574, 0.01);
    EXPECT_NEAR(high[0] / 176850, 1, 0.004);
    EXPECT_NEAR(high[1] / 110990, 1, 0.004);
}

TEST_F(DemGrid, CropAroundBlancaPeakHasItsSamplesAndSpacing) {
    const Mesh mesh = read_dem_grid(dem_, blanca(), feet());
    const size_t width = 40, height = 25;
    ASSERT_EQ(mesh.vertex_count(), width * height);
    EXPECT_EQ(mesh.triangle_count(), 2 * (width - 1) * (height - 1));
    EXPECT_NEAR(vertex(mesh, width, 12, 17)[2], 14176.16015625 * kFoot, 1e-3);  // Blanca Peak, the highest
    EXPECT_NEAR(vertex(mesh, width, 10, 10)[2], 13195.439453125 * kFoot, 1e-3);
    EXPECT_NEAR(vertex(mesh, width, 20, 30)[2], 12516.4794921875 * kFoot, 1e-3);
    for (size_t v = 0; v < mesh.vertex_count(); ++v) EXPECT_LE(mesh.positions[3 * v + 2], vertex(mesh, width, 12, 17)[2]);
    // 3 arc-seconds: 73.52 m east at the crop's latitude (37.577°N), 92.145 m north.
    const double east = std::cos((37.0 + 692.0 / 1200) * std::numbers::pi / 180) * 111320 / 1200, north = 110574.0 / 1200;
    EXPECT_NEAR(east, 73.52, 0.01);
    for (size_t i = 0; i < height; ++i)
        for (size_t j = 0; j < width; ++j) {
            EXPECT_NEAR(vertex(mesh, width, i, j)[0], j * east, 2e-3);
            EXPECT_NEAR(vertex(mesh, width, i, j)[1], i * north, 2e-3);
        }
}

TEST_F(DemGrid, TrianglesFaceUp) {
    const Mesh mesh = read_dem_grid(dem_, blanca(), feet());
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
        const float* a = &mesh.positions[3 * mesh.indices[3 * t]];
        const float* b = &mesh.positions[3 * mesh.indices[3 * t + 1]];
        const float* c = &mesh.positions[3 * mesh.indices[3 * t + 2]];
        const double normal_z = double(b[0] - a[0]) * (c[1] - a[1]) - double(b[1] - a[1]) * (c[0] - a[0]);
        ASSERT_GT(normal_z, 0) << "triangle " << t;
    }
}

TEST_F(DemGrid, WindowsToTheGridsEndStopAtItsCorners) {
    const Mesh south_west = read_dem_grid(dem_, {.columns = 3, .rows = 3}, feet());
    EXPECT_NEAR(south_west.positions[2], 8042.56005859375 * kFoot, 1e-3);
    const Mesh north_east = read_dem_grid(dem_, {.first_column = kColumns - 3, .first_row = kRows - 3}, feet());
    ASSERT_EQ(north_east.vertex_count(), 9u);
    EXPECT_NEAR(north_east.positions[3 * 8 + 2], 4490.31982421875 * kFoot, 1e-3);
    expect_error(dem_, "window columns from 2401 lie outside the grid's 2401 columns", {.first_column = kColumns});
    expect_error(dem_, "window rows from 1200 to 1201 lie outside the grid's 1201 rows", {.first_row = kRows - 1, .rows = 2});
    expect_error(dem_, "the window takes fewer than 2 rows", {.first_row = kRows - 1});
}

TEST_F(DemGrid, StrideTakesEveryKthSample) {
    const Mesh every = read_dem_grid(dem_, blanca(), feet());
    const Mesh fourth = read_dem_grid(dem_, blanca(4), feet());  // rows 680 … 704, columns 600 … 636
    const size_t width = 10;
    ASSERT_EQ(fourth.vertex_count(), width * 7);
    EXPECT_EQ(fourth.triangle_count(), 2u * 9 * 6);
    for (size_t i = 0; i < 7; ++i)
        for (size_t j = 0; j < width; ++j)
            for (int k = 0; k < 3; ++k) EXPECT_EQ(vertex(fourth, width, i, j)[k], vertex(every, 40, 4 * i, 4 * j)[k]);
}

TEST_F(DemGrid, UnitsComeFromTheAttributeOrTheCaller) {
    // trinidad.nc has no units attribute: its numbers are taken as they are unless the caller says feet.
    const Mesh as_stored = read_dem_grid(dem_, blanca());
    EXPECT_NEAR(vertex(as_stored, 40, 12, 17)[2], 14176.16, 1e-2);
    const Mesh metres = read_dem_grid(dem_, blanca(), {.variable = "data", .unit = ElevationUnit::metres});
    EXPECT_EQ(metres.positions, as_stored.positions);
    expect_error(dem_, "no variable 'elevation'", {}, {.variable = "elevation"});
    expect_error(dem_, "variable 'lat' is not a 2-D float variable", {}, {.variable = "lat"});
}

TEST_F(DemGrid, FillValuesLeaveTheirTrianglesOut) {
    // Sample (690, 610), the crop's (10, 10), set to the file's _FillValue -999 (big-endian 0xC479C000).
    const auto path = copy("filled.nc", [](std::string& bytes) {
        const size_t offset = 628 + (690 * kColumns + 610) * 4;  // the data variable begins at byte 628
        bytes.replace(offset, 4, "\xC4\x79\xC0\x00", 4);
    });
    const Mesh mesh = read_dem_grid(path, blanca(), feet());
    EXPECT_EQ(mesh.vertex_count(), 40u * 25 - 1);
    EXPECT_EQ(mesh.triangle_count(), 2u * 39 * 24 - 6);  // an inner sample is a corner of six triangles
    for (size_t v = 0; v < mesh.vertex_count(); ++v) EXPECT_GT(mesh.positions[3 * v + 2], 3000.0f);
}

TEST_F(DemGrid, BadInputNamesTheFileAndTheProblem) {
    auto unchanged = [](std::string&) {};
    expect_error(copy("header_cut.nc", unchanged, 300), "the header ends early");
    expect_error(copy("data_cut.nc", unchanged, 5'000'000),
                 "variable 'data' (1201 × 2401 floats from byte 628) runs past the end of the file (5000000 bytes)");
    expect_error(copy("coordinates_cut.nc", unchanged, 11'540'000),
                 "coordinate variable 'lat' ends at byte 11544640, past the end of the file (11540000 bytes)");
    // Only the first bytes matter to these.
    expect_error(copy("wrong_magic.nc", [](std::string& b) { b[0] = 'X'; }, 1024), "not a netCDF classic file");
    expect_error(copy("cdf2.nc", [](std::string& b) { b[3] = 2; }, 1024), "a netCDF 64-bit offset (CDF-2) file");
    expect_error(copy("hdf5.nc", [](std::string& b) { b.replace(0, 4, "\x89HDF"); }, 1024), "a netCDF-4 (HDF5) file");
    expect_error(copy("bad_tag.nc", [](std::string& b) { b[11] = 9; }, 1024), "the dimension list at byte 8 has tag 9");
    expect_error(dir_ / "absent.nc", "cannot be opened");
}

}  // namespace
}  // namespace strata::test
