#include "editor/world_file.h"

#include <cmath>
#include <cstdio>
#include <optional>

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <unistd.h>

#include "nodes/hlod_model.h"
#include "preprocess/atomic_file.h"
#include "preprocess/elevation_raster.h"
#include "preprocess/gdal_dataset.h"

namespace strata::cli {
namespace {

struct Georeference {
    std::string crs;
    glm::dvec3 origin;  // the CRS position of world (0, 0, 0)
};

// The CRS plane the scene's georeferenced models share, or why there is none.
std::optional<Georeference> scene_georeference(const Group& scene, std::string& why) {
    std::optional<Georeference> shared;
    for (size_t c = 0; c < scene.child_count(); ++c) {
        const auto* model = dynamic_cast<const HlodModel*>(scene.child(c).get());
        if (!model || model->header().crs.empty()) continue;
        const HlodHeader& h = model->header();
        if (h.terrain && h.terrain->tangent_frame()) {
            why = model->path().filename().string() + " lies in a tangent plane, not in its CRS's plane";
            return std::nullopt;
        }
        const Georeference mine{h.crs, {h.geo_origin[0], h.geo_origin[1], h.geo_origin[2]}};
        if (shared && (shared->crs != mine.crs || shared->origin != mine.origin)) {
            why = "the models are georeferenced differently";
            return std::nullopt;
        }
        shared = mine;
    }
    return shared;
}

void write_text(const std::filesystem::path& path, const std::string& text) {
    AtomicOutputFile file(path);
    file.write(text.data(), text.size());
    file.commit();
}

}  // namespace

std::optional<MapPlacement> map_placement(const Camera& camera, const Group& scene, std::string& why) {
    if (camera.projection != ProjectionKind::orthographic || camera.forward().z > -1 + 1e-9) return std::nullopt;
    const std::optional<Georeference> geo = scene_georeference(scene, why);
    if (!geo) return std::nullopt;
    // Pixel (i, j) from the top left, at its centre: the eye's x, y plus the camera's right and up axes
    // (both level, looking straight down) times its offset from the image's centre.
    const double pixel = camera.ortho_height / camera.height;
    const glm::dvec3 right = camera.orientation * glm::dvec3(1, 0, 0), up = camera.up();
    const double di = 0.5 - camera.width / 2.0, dj = camera.height / 2.0 - 0.5;
    return MapPlacement{geo->crs,
                        {right.x * pixel, right.y * pixel, -up.x * pixel, -up.y * pixel,
                         geo->origin.x + camera.position.x + (right.x * di + up.x * dj) * pixel,
                         geo->origin.y + camera.position.y + (right.y * di + up.y * dj) * pixel}};
}

WorldFiles write_world_files(const std::filesystem::path& image, const Camera& camera, const Group& scene) {
    WorldFiles out;
    const std::optional<MapPlacement> placement = map_placement(camera, scene, out.not_written);
    if (!placement) return out;
    std::string world;
    for (double term : placement->world) {
        char line[64];
        std::snprintf(line, sizeof line, "%.17g\n", term + 0.0);  // + 0.0: no "-0" for a level axis
        world += line;
    }
    const std::string extension = image.extension().string();
    std::filesystem::path world_path = image;
    world_path.replace_extension(extension.size() >= 3 ? std::string{'.', extension[1], extension.back(), 'w'} : ".wld");
    std::filesystem::path prj_path = image;
    prj_path.replace_extension(".prj");
    write_text(world_path, world);
    write_text(prj_path, crs_as_esri_wkt(placement->crs) + "\n");
    out.written = {world_path, prj_path};
    return out;
}

void write_geotiff(const Image& image, const std::filesystem::path& path, const std::optional<MapPlacement>& placement) {
    const std::vector<uint8_t> rgba = encode_srgb_rgba8(image);
    register_gdal_drivers();
    QuietGdal quiet;
    const std::filesystem::path temp = path.string() + ".tmp-" + std::to_string(::getpid()) + ".tif";
    auto fail = [&](const std::string& what) {
        std::error_code ignored;
        std::filesystem::remove(temp, ignored);
        return std::runtime_error("cannot write " + path.string() + ": " + what + QuietGdal::last());
    };
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    const char* options[] = {"PHOTOMETRIC=RGB", "ALPHA=UNASSOCIATED", "COMPRESS=DEFLATE", nullptr};
    {
        DatasetPtr tiff(driver ? driver->Create(temp.c_str(), image.width, image.height, 4, GDT_Byte, const_cast<char**>(options)) : nullptr);
        if (!tiff) throw fail("GDAL cannot create it");
        if (placement) {
            const auto& w = placement->world;  // A D B E C F; GDAL's geotransform starts at the pixel's corner
            double geotransform[6] = {w[4] - (w[0] + w[2]) / 2, w[0], w[2], w[5] - (w[1] + w[3]) / 2, w[1], w[3]};
            OGRSpatialReference crs;
            if (tiff->SetGeoTransform(geotransform) != CE_None || crs.SetFromUserInput(placement->crs.c_str()) != OGRERR_NONE ||
                tiff->SetSpatialRef(&crs) != CE_None)
                throw fail("its georeference");
        }
        tiff->GetRasterBand(4)->SetColorInterpretation(GCI_AlphaBand);
        if (tiff->RasterIO(GF_Write, 0, 0, image.width, image.height, const_cast<uint8_t*>(rgba.data()), image.width, image.height, GDT_Byte, 4,
                           nullptr, 4, GSpacing(4) * image.width, 1, nullptr) != CE_None)
            throw fail("its pixels");
        tiff->FlushCache(true);
        if (CPLGetLastErrorType() >= CE_Failure) throw fail("its pixels");
    }  // closed: complete on disk
    std::error_code error;
    std::filesystem::rename(temp, path, error);
    if (error) throw fail(error.message());
}

}  // namespace strata::cli
