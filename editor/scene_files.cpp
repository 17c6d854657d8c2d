#include "editor/scene_files.h"

#include <filesystem>
#include <stdexcept>

#include "nodes/geometry.h"
#include "nodes/hlod_model.h"

namespace strata::cli {

namespace {

HlodDebugView parse_debug_view(const std::string& name) {
    if (name == "none") return HlodDebugView::none;
    if (name == "levels") return HlodDebugView::levels;
    if (name == "wireframe") return HlodDebugView::wireframe;
    throw std::invalid_argument("unknown debug view '" + name + "' (none, levels, wireframe)");
}

}  // namespace

std::shared_ptr<Group> load_scene_files(const std::vector<std::string>& files, const SceneOptions& options) {
    auto scene = std::make_shared<Group>();
    scene->set_name("scene");
    const HlodDebugView debug_view = parse_debug_view(options.debug_view);
    for (const std::string& file : files) {
        if (std::filesystem::path(file).extension() == ".hlod") {
            auto model = HlodModel::load(file);
            model->set_pixel_error(options.pixel_error);
            model->set_morph(options.morph);
            model->set_debug_view(debug_view);
            model->set_show_cube_boxes(options.cube_boxes);
            scene->add(model);
        } else {
            scene->add(Geometry::load(file));
        }
    }
    return scene;
}

}  // namespace strata::cli
