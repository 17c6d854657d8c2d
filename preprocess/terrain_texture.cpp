#include "preprocess/terrain_texture.h"

#include <cpl_conv.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <mutex>

#include "preprocess/gdal_dataset.h"
#include "preprocess/georeference.h"
#include "preprocess/mesh.h"
#include "preprocess/parallel.h"

namespace strata {
namespace {

constexpr uint32_t kLeastAutoSize = 16, kMostAutoSize = 1024;
// A cube's footprint is mapped into the image exactly at (kControl + 1)² points and bilinearly between
// them: a projection bends far less than a pixel across an eighth of a cube.
constexpr int kControl = 8;
const std::array<uint8_t, 3> kNoImage{128, 128, 128};  // where the image has no pixel: a mid grey

// The orthophoto: its georeference, the bands that give red, green and blue, and reads of windows
// (serialised: a GDAL dataset is not thread-safe), resampled by GDAL's averaging when smaller.
class Image {
public:
    explicit Image(const TextureSettings& settings);
    // An image larger than a few thousand pixels without overviews would be read whole for every
    // coarse cube; this reads it once to average its overviews into `scratch` (a VRT over the image,
    // and its .ovr: a third of the image's pixels), removed with the Image.
    void add_overviews(const std::filesystem::path& scratch, const Progress& progress);
    ~Image();
    const std::string& name() const { return name_; }
    const std::string& crs() const { return crs_; }
    int width() const { return width_; }
    int height() const { return height_; }
    // Pixel coordinates (column, row; pixel i covers [i, i + 1)) of a CRS position.
    std::array<double, 2> pixel_of(double x, double y) const {
        return {inverse_[0] + x * inverse_[1] + y * inverse_[2], inverse_[3] + x * inverse_[4] + y * inverse_[5]};
    }
    // The window of w × h pixels from (x, y) read into bw × bh texels, 3 floats each (0‥255), and a
    // coverage per texel (0‥1: how much of it the image's mask holds).
    void read(int x, int y, int w, int h, int bw, int bh, std::vector<float>& rgb, std::vector<float>& coverage) const;

private:
    DatasetPtr dataset_;  // what the reads read: the image, or a VRT over it with overviews
    std::filesystem::path scratch_;
    std::string name_, crs_;
    std::array<double, 6> inverse_{};
    std::vector<int> bands_;
    double to_8bit_ = 1;
    int width_ = 0, height_ = 0;
    mutable std::mutex mutex_;
};

Image::Image(const TextureSettings& settings) : dataset_(open_dataset(settings.image)), name_(settings.image.string()) {
    GDALDataset& d = *dataset_;
    const int count = d.GetRasterCount();
    if (count < 1) throw InputError(name_ + ": no bands: not an image");
    bands_ = settings.bands;
    if (bands_.empty()) bands_ = count >= 3 ? std::vector<int>{1, 2, 3} : std::vector<int>{1, 1, 1};
    if (bands_.size() == 1) bands_ = {bands_[0], bands_[0], bands_[0]};
    if (bands_.size() != 3) throw InputError(name_ + ": --texture-bands names " + std::to_string(bands_.size()) + " bands; give red, green, blue (or one grey)");
    for (int b : bands_)
        if (b < 1 || b > count)
            throw InputError(name_ + ": has " + std::to_string(count) + " band" + (count == 1 ? "" : "s") + ", no band " + std::to_string(b));
    const GDALDataType type = d.GetRasterBand(bands_[0])->GetRasterDataType();
    for (int b : bands_)
        if (d.GetRasterBand(b)->GetRasterDataType() != type) throw InputError(name_ + ": the colour bands differ in sample type");
    if (type == GDT_UInt16) to_8bit_ = 1.0 / 257.0;
    else if (type != GDT_Byte)
        throw InputError(name_ + ": its samples are " + GDALGetDataTypeName(type) + "; imagery is 8-bit (Byte) or 16-bit (UInt16)");
    std::array<double, 6> g{};
    if (d.GetGeoTransform(g.data()) != CE_None) throw InputError(name_ + ": no georeference (no geotransform): the image does not say where it lies");
    if (!GDALInvGeoTransform(g.data(), inverse_.data())) throw InputError(name_ + ": a geotransform that cannot be inverted");
    const OGRSpatialReference* reference = d.GetSpatialRef();
    if (!reference) throw InputError(name_ + ": no CRS: the image does not say which coordinates its georeference is in");
    OGRSpatialReference traditional(*reference);
    traditional.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    char* wkt = nullptr;
    const char* options[] = {"FORMAT=WKT2_2019", nullptr};
    if (traditional.exportToWkt(&wkt, options) != OGRERR_NONE || !wkt) throw InputError(name_ + ": a CRS PROJ cannot write" + QuietGdal::last());
    crs_ = wkt;
    CPLFree(wkt);
    width_ = d.GetRasterXSize(), height_ = d.GetRasterYSize();
}

void Image::add_overviews(const std::filesystem::path& scratch, const Progress& progress) {
    constexpr int kLargest = 4096, kSmallestOverview = 256;
    if (std::max(width_, height_) <= kLargest || dataset_->GetRasterBand(bands_[0])->GetOverviewCount() > 0) return;
    QuietGdal quiet;
    GDALDriver* vrt = GetGDALDriverManager()->GetDriverByName("VRT");
    DatasetPtr copy(vrt ? vrt->CreateCopy(scratch.c_str(), dataset_.get(), FALSE, nullptr, nullptr, nullptr) : nullptr);
    if (!copy) throw InputError(name_ + ": cannot make its overviews in " + scratch.string() + QuietGdal::last());
    scratch_ = scratch;
    std::vector<int> factors;
    for (int f = 2; std::max(width_, height_) / f >= kSmallestOverview; f *= 2) factors.push_back(f);
    struct Report {
        const Progress* progress;
        bool cancelled = false;
    } report{&progress};
    auto on_progress = [](double done, const char*, void* data) -> int {
        auto* r = static_cast<Report*>(data);
        if (r->progress->cancelled()) return r->cancelled = true, FALSE;
        (*r->progress)("image overviews", done, 1, "");
        return TRUE;
    };
    const CPLErr status = copy->BuildOverviews("AVERAGE", int(factors.size()), factors.data(), 0, nullptr, on_progress, &report, nullptr);
    if (report.cancelled) throw Cancelled();
    if (status != CE_None) throw InputError(name_ + ": cannot make its overviews in " + scratch.string() + QuietGdal::last());
    // Read back from its file: reading the VRT CreateCopy returned, after BuildOverviews, crashes
    // inside GDAL 3.6 (a texture build over a 6k × 4k image did); the one opened anew does not.
    copy.reset();
    dataset_ = open_dataset(scratch);
}

Image::~Image() {
    dataset_.reset();
    if (scratch_.empty()) return;
    std::error_code ignored;
    std::filesystem::remove(scratch_, ignored);
    std::filesystem::remove(scratch_.string() + ".ovr", ignored);
}

void Image::read(int x, int y, int w, int h, int bw, int bh, std::vector<float>& rgb, std::vector<float>& coverage) const {
    const size_t texels = size_t(bw) * size_t(bh);
    rgb.assign(texels * 3, 0.0f);
    std::vector<uint8_t> mask(texels);
    GDALRasterIOExtraArg extra;
    INIT_RASTERIO_EXTRA_ARG(extra);
    extra.eResampleAlg = bw < w || bh < h ? GRIORA_Average : GRIORA_NearestNeighbour;
    std::lock_guard lock(mutex_);
    QuietGdal quiet;
    GDALDataset& d = *dataset_;
    CPLErr status = CE_None;
    for (int c = 0; c < 3 && status == CE_None; ++c)
        status = d.GetRasterBand(bands_[size_t(c)])->RasterIO(GF_Read, x, y, w, h, rgb.data() + c, bw, bh, GDT_Float32, 3 * sizeof(float),
                                                             GSpacing(3 * sizeof(float)) * bw, &extra);
    if (status == CE_None)
        status = d.GetRasterBand(bands_[0])->GetMaskBand()->RasterIO(GF_Read, x, y, w, h, mask.data(), bw, bh, GDT_Byte, 0, 0, &extra);
    if (status != CE_None)
        throw InputError(name_ + ": cannot read pixels " + std::to_string(x) + ".." + std::to_string(x + w - 1) + " of rows " + std::to_string(y) + ".." +
                         std::to_string(y + h - 1) + QuietGdal::last());
    for (float& v : rgb) v = float(v * to_8bit_);
    coverage.resize(texels);
    for (size_t t = 0; t < texels; ++t) coverage[t] = float(mask[t]) / 255.0f;
}

// A cube's footprint in the model's x and y (its cell grown by the margin) and the image pixels its
// (kControl + 1)² control points fall on.
struct Footprint {
    std::array<std::array<double, 2>, (kControl + 1) * (kControl + 1)> pixel{};
    double lo[2], hi[2];  // the pixels' bounding box
};

// The model point on the ground under model (x, y), starting from height `z`: in the ecef frame the
// ground's height moves the point that (x, y) stands for; in the others z does not matter.
std::array<double, 3> on_ground(double x, double y, double z, const HlodHeader& header, const Georeference& geo, const GroundHeight& ground) {
    if (!header.terrain || header.terrain->frame != uint32_t(TerrainFrameKind::ecef)) return {x, y, z};
    // The height above the ellipsoid of the ground under (x, y), a few rounds from the model point's own
    // (each finds the raster position for the last height), then the model z of the point at that height
    // (Newton: a metre of z is about a metre of height, the up direction turning by d/R).
    double height = geo.model_to_crs({x, y, z})[2];
    for (int round = 0; round < 4; ++round) {
        const std::optional<std::array<double, 2>> at = geo.raster_position(x, y, height);
        const std::optional<double> h = at ? ground((*at)[0], (*at)[1]) : std::nullopt;
        if (!h) break;
        height = *h;
    }
    for (int round = 0; round < 4; ++round) z += height - geo.model_to_crs({x, y, z})[2];
    return {x, y, z};
}

Footprint footprint(const HlodNode& node, const HlodHeader& header, float margin, const Georeference& geo, const Image& image,
                    const GroundHeight& ground) {
    const double s = header.cube_size(node.level), cell[3] = {double(node.i), double(node.j), double(node.k)};
    Footprint f;
    f.lo[0] = f.lo[1] = INFINITY, f.hi[0] = f.hi[1] = -INFINITY;
    for (int b = 0; b <= kControl; ++b)
        for (int a = 0; a <= kControl; ++a) {
            const std::array<double, 3> model =
                on_ground(header.origin[0] + (cell[0] - margin + (1 + 2 * margin) * a / kControl) * s,
                          header.origin[1] + (cell[1] - margin + (1 + 2 * margin) * b / kControl) * s, header.origin[2] + (cell[2] + 0.5) * s,
                          header, geo, ground);
            const std::array<double, 3> at = geo.to_geo(model, image.crs());
            const std::array<double, 2> p = image.pixel_of(at[0], at[1]);
            f.pixel[size_t(b * (kControl + 1) + a)] = p;
            for (int axis = 0; axis < 2; ++axis) f.lo[axis] = std::min(f.lo[axis], p[axis]), f.hi[axis] = std::max(f.hi[axis], p[axis]);
        }
    return f;
}

// The image pixel under texel (column, row) of a texture of `size` texels, between the control points.
std::array<double, 2> pixel_at(const Footprint& f, uint32_t column, uint32_t row, uint32_t size) {
    const double u = (column + 0.5) / size * kControl, v = (row + 0.5) / size * kControl;
    const int a = std::min(int(u), kControl - 1), b = std::min(int(v), kControl - 1);
    const double fu = u - a, fv = v - b;
    const auto& p00 = f.pixel[size_t(b * (kControl + 1) + a)];
    const auto& p10 = f.pixel[size_t(b * (kControl + 1) + a + 1)];
    const auto& p01 = f.pixel[size_t((b + 1) * (kControl + 1) + a)];
    const auto& p11 = f.pixel[size_t((b + 1) * (kControl + 1) + a + 1)];
    std::array<double, 2> p{};
    for (int axis = 0; axis < 2; ++axis)
        p[size_t(axis)] = (p00[size_t(axis)] * (1 - fu) + p10[size_t(axis)] * fu) * (1 - fv) + (p01[size_t(axis)] * (1 - fu) + p11[size_t(axis)] * fu) * fv;
    return p;
}

// A texture where the image has no pixel: grey.
void fill_without_image(std::vector<uint8_t>& rgb, uint32_t size) {
    rgb.resize(size_t(size) * size * 3);
    for (size_t t = 0; t < rgb.size(); t += 3) std::copy(kNoImage.begin(), kNoImage.end(), rgb.begin() + ptrdiff_t(t));
}

// The cube's texture as RGB8, row 0 at the footprint's south edge; false when the image has no pixel
// under it (it is then grey).
bool sample_texture(const Footprint& f, const Image& image, uint32_t size, std::vector<uint8_t>& rgb) {
    rgb.resize(size_t(size) * size * 3);
    // Off the image (or not a number): no pixel. Otherwise the window's bounds lie within a few pixels
    // of the image's, so they fit an int.
    if (!(f.hi[0] >= 0 && f.hi[1] >= 0 && f.lo[0] <= image.width() && f.lo[1] <= image.height())) {
        fill_without_image(rgb, size);
        return false;
    }
    const int x0 = std::max(0, int(std::floor(std::max(f.lo[0], 0.0))) - 2), y0 = std::max(0, int(std::floor(std::max(f.lo[1], 0.0))) - 2);
    const int x1 = std::min(image.width(), int(std::ceil(std::min(f.hi[0], double(image.width())))) + 2);
    const int y1 = std::min(image.height(), int(std::ceil(std::min(f.hi[1], double(image.height())))) + 2);
    // Read the window at about the texture's density: GDAL averages the pixels a texel covers.
    const int w = x1 - x0, h = y1 - y0;
    const double span = std::max(f.hi[0] - f.lo[0], f.hi[1] - f.lo[1]);
    const int shrink = std::max(1, int(span / size));
    const int bw = std::max(1, (w + shrink - 1) / shrink), bh = std::max(1, (h + shrink - 1) / shrink);
    std::vector<float> window, coverage;
    image.read(x0, y0, w, h, bw, bh, window, coverage);
    const double sx = double(bw) / w, sy = double(bh) / h;
    for (uint32_t row = 0; row < size; ++row)
        for (uint32_t column = 0; column < size; ++column) {
            const std::array<double, 2> p = pixel_at(f, column, row, size);
            uint8_t* out = &rgb[(size_t(row) * size + column) * 3];
            // Bilinear between the window's texel centres, weighting by the mask's coverage.
            const double u = std::clamp((p[0] - x0) * sx - 0.5, 0.0, bw - 1.0), v = std::clamp((p[1] - y0) * sy - 0.5, 0.0, bh - 1.0);
            const int a = std::min(int(u), bw - 1), b = std::min(int(v), bh - 1);
            const int a1 = std::min(a + 1, bw - 1), b1 = std::min(b + 1, bh - 1);
            const double fu = u - a, fv = v - b;
            double sum[3] = {0, 0, 0}, weight = 0;
            const bool inside = p[0] >= 0 && p[1] >= 0 && p[0] <= image.width() && p[1] <= image.height();
            for (int corner = 0; corner < 4 && inside; ++corner) {
                const size_t t = size_t(corner & 2 ? b1 : b) * size_t(bw) + size_t(corner & 1 ? a1 : a);
                const double w8 = (corner & 1 ? fu : 1 - fu) * (corner & 2 ? fv : 1 - fv) * coverage[t];
                for (int c = 0; c < 3; ++c) sum[c] += w8 * window[3 * t + size_t(c)];
                weight += w8;
            }
            for (int c = 0; c < 3; ++c)
                out[c] = weight > 1e-6 ? uint8_t(std::clamp(std::lround(sum[c] / weight), 0l, 255l)) : kNoImage[size_t(c)];
        }
    return true;
}

// Image pixels per model unit at the model's centre, on the coarser axis of the image.
double pixels_per_unit(const HlodHeader& header, const Georeference& geo, const Image& image) {
    std::array<double, 3> centre{};
    for (int a = 0; a < 3; ++a) centre[size_t(a)] = (header.bounds_lo[a] + header.bounds_hi[a]) / 2;
    const double step = header.cube_size(header.max_level) / 4;
    auto pixel = [&](double dx, double dy) {
        const std::array<double, 3> at = geo.to_geo({centre[0] + dx, centre[1] + dy, centre[2]}, image.crs());
        return image.pixel_of(at[0], at[1]);
    };
    const std::array<double, 2> p = pixel(0, 0), px = pixel(step, 0), py = pixel(0, step);
    return std::max(std::hypot(px[0] - p[0], px[1] - p[1]), std::hypot(py[0] - p[0], py[1] - p[1])) / step;
}

}  // namespace

void check_texture_image(const TextureSettings& settings) {
    if (settings.size && !TextureLayout::valid_size(settings.size))
        throw InputError(settings.image.string() + ": textures of " + std::to_string(settings.size) + " texels; a power of two from 8 to 4096");
    Image image(settings);
}

TextureReport build_terrain_textures(const TextureSettings& settings, const HlodHeader& header, float margin, HlodWriter& writer,
                                     const std::filesystem::path& scratch, const GroundHeight& ground, unsigned threads,
                                     const Progress& progress) {
    const auto start = std::chrono::steady_clock::now();
    Image image(settings);
    image.add_overviews(scratch, progress);
    const Georeference geo(header, header.source);
    TextureReport report;
    report.image = image.name();
    double density = 0;
    try {
        density = pixels_per_unit(header, geo, image);
    } catch (const std::runtime_error& e) {  // PROJ: no way between the two CRSs, or not at the terrain
        throw InputError(image.name() + ": " + e.what());
    }
    if (!(density > 0) || !std::isfinite(density)) throw InputError(image.name() + ": its georeference does not place it on the terrain");
    report.image_metres = 1 / density;
    TextureLayout& layout = report.layout;
    layout.margin = margin;
    if (settings.size) {
        layout.size = settings.size;
    } else {  // the finest level as dense as the image, within a fifth (a power of two apart is too coarse a choice)
        const double texels = (1 + 2 * double(margin)) * header.cube_size(header.max_level) * density / 1.2;
        layout.size = std::clamp(std::bit_ceil(uint32_t(std::clamp(std::ceil(texels), 1.0, double(kMostAutoSize)))), kLeastAutoSize, kMostAutoSize);
    }
    TextureSectionWriter section(writer, layout);
    const std::vector<HlodNode> cubes = writer.nodes_in_file_order();
    std::atomic<uint64_t> covered{0}, done{0};
    std::mutex progress_lock;
    parallel_for(cubes.size(), threads, [&](size_t c, unsigned) {
        progress.check();
        const HlodNode& node = cubes[c];
        std::vector<uint8_t> rgb;
        try {
            if (sample_texture(footprint(node, header, margin, geo, image, ground), image, layout.size, rgb)) ++covered;
        } catch (const InputError&) {
            throw;  // the image's pixels cannot be read
        } catch (const std::runtime_error&) {  // PROJ cannot map the cube's ground into the image's CRS: no image there
            fill_without_image(rgb, layout.size);
        }
        section.add(node.level, node.i, node.j, node.k, encode_bc1_chain(rgb, layout.size));
        std::lock_guard lock(progress_lock);
        progress("textures", double(++done), double(cubes.size()), "cubes");
    });
    if (covered == 0) throw InputError(image.name() + ": the image does not overlap the terrain");
    section.finish();
    report.textures = cubes.size();
    report.stored_bytes = section.bytes();
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
}

}  // namespace strata
