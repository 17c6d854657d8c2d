// strata.path{…}: camera flythrough paths (engine/path) as Lua values of type "strata.Path": sampled by
// time or frame by frame at a frame rate, saved and loaded as JSON, imported from and exported to
// OpenSceneGraph .path files. Poses are tables {position=, orientation=, fov=} that camera:set_pose takes.
#include <cmath>

#include <lua.hpp>

#include "engine/path/camera_path.h"
#include "engine/path/osg_path.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"
#include "scripting/wrap_path.h"

namespace strata {

namespace {

void push_path(lua_State* L, CameraPath path) {
    lua::push_shared(L, std::make_shared<CameraPath>(std::move(path)));
}

const CameraPath& check_path(lua_State* L, int index) { return *lua::check_shared<CameraPath>(L, index); }

void push_pose(lua_State* L, const Pose& pose) { lua::push_pose(L, pose.position, pose.orientation, pose.fov_degrees); }

// A vec3 option of the table at `index`, if present.
std::optional<glm::dvec3> opt_vec3(lua_State* L, int index, const char* key) {
    std::optional<glm::dvec3> value;
    if (lua::get_option(L, index, key)) value = lua::check_vec3(L, lua_gettop(L));
    lua_pop(L, 1);
    return value;
}

Keyframe check_key(lua_State* L, int index) {
    lua::check_keys(L, index, {"position", "orientation", "target", "fov", "duration", "handle_in", "handle_out"});
    Keyframe key;
    const auto position = opt_vec3(L, index, "position");
    if (!position) luaL_error(L, "a key needs a 'position'");
    key.position = *position;
    if (lua::get_option(L, index, "orientation")) key.orientation = lua::check_quat(L, lua_gettop(L));
    lua_pop(L, 1);
    key.target = opt_vec3(L, index, "target");
    key.fov_degrees = lua::opt_number(L, index, "fov", key.fov_degrees);
    if (lua::get_option(L, index, "duration")) key.duration = lua::opt_number(L, index, "duration", 0);
    lua_pop(L, 1);
    key.handles.in = opt_vec3(L, index, "handle_in");
    key.handles.out = opt_vec3(L, index, "handle_out");
    return key;
}

// The options shared by strata.path and strata.import_osg_path.
PathOptions check_options(lua_State* L, int index) {
    PathOptions o;
    const std::string spline = lua::opt_string(L, index, "spline", std::string(to_string(o.positions)));
    const std::string orientation = lua::opt_string(L, index, "orientation", std::string(to_string(o.orientations)));
    const std::string easing = lua::opt_string(L, index, "easing", std::string(to_string(o.easing)));
    const std::string speed = lua::opt_string(L, index, "speed", "constant");
    const auto positions = parse_interpolation(spline);
    const auto orientations = parse_orientation_interpolation(orientation);
    const auto ease = parse_easing(easing);
    if (!positions) luaL_error(L, "option 'spline' must be catmull-rom, bezier or linear, not '%s'", spline.c_str());
    if (!orientations) luaL_error(L, "option 'orientation' must be squad, slerp or look-at, not '%s'", orientation.c_str());
    if (!ease) luaL_error(L, "option 'easing' must be none, ease-in, ease-out or ease-in-out, not '%s'", easing.c_str());
    if (speed != "constant" && speed != "natural") luaL_error(L, "option 'speed' must be constant or natural, not '%s'", speed.c_str());
    o.positions = *positions;
    o.orientations = *orientations;
    o.easing = *ease;
    o.constant_speed = speed == "constant";
    if (lua::get_option(L, index, "duration")) o.total_duration = lua::opt_number(L, index, "duration", 0);
    lua_pop(L, 1);
    if (lua::get_option(L, index, "ease_seconds")) o.ease_seconds = lua::opt_number(L, index, "ease_seconds", 0);
    lua_pop(L, 1);
    if (const auto up = opt_vec3(L, index, "up")) o.up = *up;
    return o;
}

int new_path(lua_State* L) {
    luaL_checktype(L, 1, LUA_TTABLE);
    lua::check_keys(L, 1, {"keys", "spline", "orientation", "easing", "speed", "duration", "ease_seconds", "up"});
    const PathOptions options = check_options(L, 1);
    lua_getfield(L, 1, "keys");
    if (!lua_istable(L, -1)) return luaL_error(L, "strata.path needs 'keys', a list of keyframes");
    const int keys_index = lua_gettop(L);
    std::vector<Keyframe> keys;
    for (lua_Integer i = 1; i <= lua_Integer(lua_rawlen(L, keys_index)); ++i) {
        lua_rawgeti(L, keys_index, i);
        if (!lua_istable(L, -1)) return luaL_error(L, "key %d is not a table", int(i));
        keys.push_back(check_key(L, lua_gettop(L)));
        lua_pop(L, 1);
    }
    try {
        push_path(L, CameraPath::from_keys(std::move(keys), options));
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 1;
}

int load_path(lua_State* L) {
    try {
        push_path(L, CameraPath::load(luaL_checkstring(L, 1)));
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 1;
}

int import_osg(lua_State* L) {
    const char* file = luaL_checkstring(L, 1);
    lua::check_keys(L, 2, {"spline", "orientation", "easing", "speed", "duration", "ease_seconds", "up"});
    const PathOptions options = check_options(L, 2);
    try {
        push_path(L, import_osg_path(file, options));
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 1;
}

int path_sample(lua_State* L) {
    const CameraPath& path = check_path(L, 1);
    const double seconds = luaL_checknumber(L, 2);
    luaL_argcheck(L, std::isfinite(seconds), 2, "a finite time in seconds expected");
    push_pose(L, path.sample(seconds));
    return 1;
}

int path_duration(lua_State* L) {
    lua_pushnumber(L, check_path(L, 1).duration());
    return 1;
}

int path_length(lua_State* L) {
    lua_pushnumber(L, check_path(L, 1).length());
    return 1;
}

int path_key_time(lua_State* L) {
    const CameraPath& path = check_path(L, 1);
    const lua_Integer key = luaL_checkinteger(L, 2);
    luaL_argcheck(L, key >= 1 && key <= lua_Integer(path.key_count()), 2, "no such key");
    lua_pushnumber(L, path.key_time(size_t(key - 1)));
    return 1;
}

// Up to a million: a frame count is duration × fps, which must stay a count.
double check_fps(lua_State* L, int index) {
    const double fps = lua::opt_number(L, index, "fps", 30);
    if (!(fps > 0 && fps <= 1e6)) luaL_error(L, "option 'fps' must be positive, up to 1000000");
    return fps;
}

int path_frame_count(lua_State* L) {
    const CameraPath& path = check_path(L, 1);
    lua::check_keys(L, 2, {"fps"});
    lua_pushinteger(L, lua_Integer(path.frame_count(check_fps(L, 2))));
    return 1;
}

// How far ahead of a path's frame strata.render prefetches: the frames this many seconds on.
constexpr double kPrefetchSeconds[] = {0.25, 0.5, 1.0};

// for i, pose in path:frames{ fps = 30 } do … end — frame i (from 1) at (i − 1)/fps seconds. Each step
// also tells the runtime the poses of the frames a quarter, a half and a whole second on (the last
// frame at most), which strata.render prefetches for; the loop's end clears them.
int frames_step(lua_State* L) {
    const CameraPath& path = check_path(L, lua_upvalueindex(1));
    const double fps = lua_tonumber(L, lua_upvalueindex(2));
    const lua_Integer previous = luaL_checkinteger(L, 2);  // the control value: a script may pass any
    std::vector<RenderSettings::Pose>& upcoming = Runtime::of(L).upcoming_poses();
    upcoming.clear();
    const uint64_t count = path.frame_count(fps);
    if (previous < 0 || uint64_t(previous) >= count) return 0;
    const lua_Integer i = previous + 1;
    lua_pushinteger(L, i);
    push_pose(L, path.sample(double(i - 1) / fps));
    double last = double(i - 1);  // frames counted from 0
    for (const double ahead : kPrefetchSeconds) {
        const double frame = std::min(double(i - 1) + std::ceil(ahead * fps), double(count - 1));
        if (frame <= last) continue;
        last = frame;
        const Pose pose = path.sample(frame / fps);
        upcoming.push_back({pose.position, pose.orientation, pose.fov_degrees});
    }
    return 2;
}

// The loop's closing value: its __close (at the end, a break or an error) clears the poses to come.
int clear_upcoming(lua_State* L) {
    Runtime::of(L).upcoming_poses().clear();
    return 0;
}

int path_frames(lua_State* L) {
    check_path(L, 1);
    lua::check_keys(L, 2, {"fps"});
    const double fps = check_fps(L, 2);
    lua_pushvalue(L, 1);
    lua_pushnumber(L, fps);
    lua_pushcclosure(L, frames_step, 2);
    lua_pushnil(L);
    lua_pushinteger(L, 0);
    lua_newtable(L);
    if (luaL_newmetatable(L, "strata.PathFramesEnd")) {
        lua_pushcfunction(L, clear_upcoming);
        lua_setfield(L, -2, "__close");
        lua_pushboolean(L, false);
        lua_setfield(L, -2, "__metatable");  // scripts cannot take its __close away
    }
    lua_setmetatable(L, -2);
    return 4;
}

int path_save(lua_State* L) {
    try {
        check_path(L, 1).save(luaL_checkstring(L, 2));
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 0;
}

int path_export_osg(lua_State* L) {
    const CameraPath& path = check_path(L, 1);
    const char* file = luaL_checkstring(L, 2);
    lua::check_keys(L, 3, {"fps"});
    std::optional<double> fps;
    if (lua::get_option(L, 3, "fps")) fps = check_fps(L, 3);
    lua_pop(L, 1);
    try {
        export_osg_path(path, file, fps);
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 0;
}

int path_to_json(lua_State* L) {
    lua_pushstring(L, check_path(L, 1).to_json().c_str());
    return 1;
}

const luaL_Reg kMethods[] = {{"sample", path_sample},       {"duration", path_duration},
                             {"length", path_length},       {"key_time", path_key_time},
                             {"frame_count", path_frame_count}, {"frames", path_frames},
                             {"save", path_save},           {"export_osg", path_export_osg},
                             {"json", path_to_json},        {nullptr, nullptr}};

}  // namespace

void register_path(lua_State* L) {
    lua::register_type<CameraPath>(L, kPathType, kMethods);
    const luaL_Reg functions[] = {{"path", new_path}, {"load_path", load_path}, {"import_osg_path", import_osg},
                                  {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata
