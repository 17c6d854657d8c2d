// Scene scripts: a scene saved as a Lua script that rebuilds it. The convention, shared by `strata run`,
// `strata shell SCENE.lua` and the editor (`strata view SCENE.lua`): a scene script sets the globals
//   scene      the root node
//   camera     a strata camera (optional)
//   bookmarks  an array of { name = "…", position = {x,y,z}, orientation = {w,x,y,z}, fov = degrees }
//   paths      a table name → strata path
// and names its model and mesh files relative to its own folder, so a project folder can move.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/path/camera_path.h"
#include "engine/scene/camera.h"
#include "engine/scene/node.h"

struct lua_State;

namespace strata {

// A named viewpoint: what camera:pose() gives and camera:set_pose takes.
struct Bookmark {
    std::string name;
    glm::dvec3 position{0, 0, 0};
    glm::dquat orientation{1, 0, 0, 0};
    double fov_degrees = 50;
};

struct SceneState {
    NodePtr scene;
    std::shared_ptr<Camera> camera;  // may be null
    std::vector<Bookmark> bookmarks;
    std::vector<std::pair<std::string, std::shared_ptr<CameraPath>>> paths;  // written in this order
};

// The script that rebuilds `state` when run from `script_path` (or from wherever that folder moves):
// readable, one statement per line, nested as the scene is, and exact (every number round-trips bit
// for bit). Throws std::runtime_error naming the node when one cannot be written: a type the script
// has no constructor for, or a geometry built in code.
std::string scene_to_lua(const SceneState& state, const std::filesystem::path& script_path);

// Writes scene_to_lua's script to `script_path` through a temporary file renamed into place: a failure
// leaves no file. Throws std::runtime_error naming the file.
void save_scene_script(const SceneState& state, const std::filesystem::path& script_path);

// The state of the globals `scene`, `camera`, `bookmarks` and `paths` in `L` (after a scene script ran
// there); bookmarks hold what camera:set_pose takes. Throws std::runtime_error when `scene` is missing
// or a global is of the wrong type. (wrap_scene_script.cpp, beside strata.save_scene.)
SceneState read_scene_globals(lua_State* L);

}  // namespace strata
