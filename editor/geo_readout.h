// Where the view is on the Earth (issue 17 §3): for a scene holding a georeferenced model, the
// camera's and the cursor's longitude, latitude and height on that model's CRS datum, and over a
// terrain how high the camera is above the ground below it. The model read from is the selected one
// when it is georeferenced, else the first georeferenced model in the scene.
#pragma once

#include <array>
#include <optional>
#include <string>

#include <glm/glm.hpp>

#include "engine/scene/node.h"

namespace strata {

class HlodModel;

struct GeoReading {
    std::array<double, 3> geo{};         // longitude, latitude (degrees), height (metres)
    std::optional<double> above_ground;  // terrains: height above the raster's ground below
};

class GeoReadout {
public:
    // Finds the model to read from (again each frame: the scene and the selection change).
    void update(const Group& scene, const Node* selected);
    bool active() const { return model_ != nullptr; }
    const std::string& model_name() const { return model_name_; }
    const std::string& crs_label() const { return crs_label_; }  // "EPSG:32613 WGS 84 / UTM zone 13N"
    // A point of the world frame, read on the model; nothing without a model, or where its CRS has no
    // coordinates for it.
    std::optional<GeoReading> read(const glm::dvec3& world) const;
    // "37.512345° N, 104.987654° W, 2 345.6 m (312.4 m above the ground)".
    static std::string describe(const GeoReading& reading);

private:
    const HlodModel* model_ = nullptr;
    glm::dmat4 world_to_model_{1.0};
    std::string model_name_, crs_, crs_label_;
};

}  // namespace strata
