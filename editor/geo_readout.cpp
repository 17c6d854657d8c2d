#include "editor/geo_readout.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>
#include <vector>

#include "nodes/hlod_model.h"
#include "preprocess/elevation_raster.h"
#include "preprocess/georeference.h"

namespace strata {
namespace {

struct Found {
    const HlodModel* model = nullptr;
    glm::dmat4 model_to_world{1.0};
};

// Depth first from the scene (with an explicit stack: scenes may be any number of levels deep): the
// preferred node when it is a georeferenced model, else the first georeferenced model met.
Found search(const Group& scene, const Node* preferred) {
    Found first;
    std::vector<std::pair<const Node*, glm::dmat4>> stack{{&scene, glm::dmat4(1.0)}};
    while (!stack.empty()) {
        const auto [node, to_world] = stack.back();
        stack.pop_back();
        glm::dmat4 frame = to_world;
        if (const auto* transform = dynamic_cast<const Transform*>(node)) frame = to_world * transform->matrix();
        if (const auto* model = dynamic_cast<const HlodModel*>(node); model && model->georeference()) {
            if (node == preferred) return {model, frame};
            if (!first.model) first = {model, frame};
        }
        if (const auto* group = dynamic_cast<const Group*>(node))
            for (auto child = group->children().rbegin(); child != group->children().rend(); ++child) stack.emplace_back(child->get(), frame);
    }
    return first;
}

}  // namespace

void GeoReadout::update(const Group& scene, const Node* selected) {
    const Found found = search(scene, selected);
    model_ = found.model;
    if (!model_) return;
    world_to_model_ = glm::inverse(found.model_to_world);
    model_name_ = model_->name();
    if (crs_ != model_->header().crs) {  // PROJ's database is asked once per CRS, not every frame
        crs_ = model_->header().crs;
        crs_label_ = describe_crs(crs_);
    }
}

std::optional<GeoReading> GeoReadout::read(const glm::dvec3& world) const {
    if (!model_) return std::nullopt;
    const glm::dvec3 local = glm::dvec3(world_to_model_ * glm::dvec4(world, 1.0));
    GeoReading reading;
    try {
        reading.geo = model_->georeference()->to_geo({local.x, local.y, local.z});
    } catch (const std::runtime_error&) {
        return std::nullopt;  // beyond what the CRS maps: no reading
    }
    // The point's own height above the ground's (in the ecef frame model z is not a height).
    try {
        if (model_->header().terrain)
            if (const std::optional<double> ground = model_->height_at(local.x, local.y)) reading.above_ground = reading.geo[2] - *ground;
    } catch (const std::runtime_error&) {
        // a terrain without heights (or with corrupt ones): the place without the height above ground
    }
    return reading;
}

std::string GeoReadout::describe(const GeoReading& r) {
    char text[160];
    const int n = std::snprintf(text, sizeof text, "%.6f° %c, %.6f° %c, %.1f m", std::abs(r.geo[1]), r.geo[1] < 0 ? 'S' : 'N',
                                std::abs(r.geo[0]), r.geo[0] < 0 ? 'W' : 'E', r.geo[2]);
    std::string out(text, size_t(std::max(n, 0)));
    if (r.above_ground) {
        std::snprintf(text, sizeof text, " (%.1f m above the ground)", *r.above_ground);
        out += text;
    }
    return out;
}

}  // namespace strata
