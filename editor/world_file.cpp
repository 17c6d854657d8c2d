#include "editor/world_file.h"

#include <cmath>
#include <cstdio>
#include <optional>

#include "nodes/hlod_model.h"
#include "preprocess/atomic_file.h"
#include "preprocess/elevation_raster.h"

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

WorldFiles write_world_files(const std::filesystem::path& image, const Camera& camera, const Group& scene) {
    WorldFiles out;
    if (camera.projection != ProjectionKind::orthographic || camera.forward().z > -1 + 1e-9) return out;
    const std::optional<Georeference> geo = scene_georeference(scene, out.not_written);
    if (!geo) return out;

    // Pixel (i, j) from the top left, at its centre: the eye's x, y plus the camera's right and up axes
    // (both level, looking straight down) times its offset from the image's centre.
    const double pixel = camera.ortho_height / camera.height;
    const glm::dvec3 right = camera.orientation * glm::dvec3(1, 0, 0), up = camera.up();
    const double di = 0.5 - camera.width / 2.0, dj = camera.height / 2.0 - 0.5;
    const double terms[6] = {right.x * pixel,
                             right.y * pixel,
                             -up.x * pixel,
                             -up.y * pixel,
                             geo->origin.x + camera.position.x + (right.x * di + up.x * dj) * pixel,
                             geo->origin.y + camera.position.y + (right.y * di + up.y * dj) * pixel};
    std::string world;
    for (double term : terms) {
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
    write_text(prj_path, crs_as_esri_wkt(geo->crs) + "\n");
    out.written = {world_path, prj_path};
    return out;
}

}  // namespace strata::cli
