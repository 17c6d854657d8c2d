// strata.view: the editor from Lua. In the REPL the window is drawn between keystrokes while the prompt
// stays live; in `strata run` and `strata view` it stays until closed. The editor object's methods
// drive it as a person would (select, add keys, scrub, bookmarks, the console, screenshots): what
// scripted tests and capture set-ups use.
#include "editor/wrap_editor.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <lua.hpp>

#include "engine/io/image.h"
#include "scripting/lua_util.h"
#include "scripting/wrap_camera.h"
#include "scripting/wrap_scene.h"
#include "scripting/wrap_terrain.h"

namespace strata {

namespace {

constexpr const char* kEditorType = "strata.Editor";
constexpr const char* kOpenEditor = "strata.open_editor";  // registry key of the one editor

// The handle may be empty: a later strata.view() replaced the editor it held.
const std::shared_ptr<Editor>& check_handle(lua_State* L) { return lua::check_slot<Editor>(L, 1); }

Editor& check_editor(lua_State* L) {
    const std::shared_ptr<Editor>& editor = check_handle(L);
    if (!editor || !editor->open()) luaL_error(L, "the editor's window is closed: call strata.view() to open it again");
    return *editor;
}

// A method body that may throw (bad file, bad path): the exception becomes a Lua error.
template <typename Action>
int guarded(lua_State* L, Action&& action) {
    try {
        return action();
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
}

// A 1-based key index from Lua, checked against the keys there are.
size_t check_key(lua_State* L, int index, const Editor& editor) {
    const lua_Integer key = luaL_checkinteger(L, index);
    const size_t count = const_cast<Editor&>(editor).path().keys().size();
    luaL_argcheck(L, key >= 1 && size_t(key) <= count, index, "no such key");
    return size_t(key - 1);
}

int editor_frame(lua_State* L) {  // ed:frame([n]) → open
    const std::shared_ptr<Editor> editor = check_handle(L);  // a copy: the handle is the Lua state's
    const lua_Integer frames = luaL_optinteger(L, 2, 1);
    bool open = editor && editor->open();
    for (lua_Integer i = 0; i < frames && open; ++i) open = guarded(L, [&] { return int(editor->frame()); });
    lua_pushboolean(L, open);
    return 1;
}

int editor_is_open(lua_State* L) {
    const std::shared_ptr<Editor>& editor = check_handle(L);
    lua_pushboolean(L, editor && editor->open());
    return 1;
}

int editor_close(lua_State* L) {
    if (const std::shared_ptr<Editor>& editor = check_handle(L)) editor->close();
    return 0;
}

int editor_select(lua_State* L) {  // ed:select(node | name | nil) → the node
    Editor& editor = check_editor(L);
    NodePtr node;
    if (lua_type(L, 2) == LUA_TSTRING) {
        node = find_node(NodePtr(editor.scene_pointer()), lua_tostring(L, 2));
        if (!node) return luaL_error(L, "no node named '%s' in the scene", lua_tostring(L, 2));
    } else if (!lua_isnoneornil(L, 2)) {
        node = check_node(L, 2);
    }
    editor.select(node);
    if (!node) return 0;
    push_node(L, node);
    return 1;
}

int editor_selected(lua_State* L) {
    const NodePtr node = check_editor(L).selected();
    if (!node) return 0;
    push_node(L, node);
    return 1;
}

int editor_add(lua_State* L) {  // ed:add(file) → the node, selected
    Editor& editor = check_editor(L);
    const std::string file = luaL_checkstring(L, 2);
    return guarded(L, [&] {
        push_node(L, editor.add_file(file));
        return 1;
    });
}

int editor_remove(lua_State* L) {
    check_editor(L).remove(check_node(L, 2));
    return 0;
}

int editor_scene(lua_State* L) {
    push_node(L, check_editor(L).scene_pointer());
    return 1;
}

int editor_camera(lua_State* L) {
    push_camera(L, check_editor(L).camera_pointer());
    return 1;
}

// ---- the path ----

int editor_add_key(lua_State* L) {  // ed:add_key() → the number of keys
    Editor& editor = check_editor(L);
    editor.path().add_key();
    lua_pushinteger(L, lua_Integer(editor.path().keys().size()));
    return 1;
}

int editor_move_key(lua_State* L) {
    Editor& editor = check_editor(L);
    editor.path().move_key(check_key(L, 2, editor));
    return 0;
}

int editor_remove_key(lua_State* L) {
    Editor& editor = check_editor(L);
    editor.path().remove_key(check_key(L, 2, editor));
    return 0;
}

int editor_set_duration(lua_State* L) {  // ed:set_duration(key, seconds | nil): the segment after the key
    Editor& editor = check_editor(L);
    const size_t key = check_key(L, 2, editor);
    luaL_argcheck(L, key + 1 < editor.path().keys().size(), 2, "the last key has no segment after it");
    std::optional<double> seconds;
    if (!lua_isnoneornil(L, 3)) {
        seconds = luaL_checknumber(L, 3);
        luaL_argcheck(L, *seconds > 0 && std::isfinite(*seconds), 3, "a duration must be a finite number > 0");
    }
    editor.path().set_duration(key, seconds);
    return 0;
}

int editor_keys(lua_State* L) {
    lua_pushinteger(L, lua_Integer(check_editor(L).path().keys().size()));
    return 1;
}

int editor_duration(lua_State* L) {  // ed:duration() → seconds, or nil and why while there is no path
    const PathEditor& path = check_editor(L).path();
    if (!path.path()) {
        lua_pushnil(L);
        lua_pushstring(L, path.error().c_str());
        return 2;
    }
    lua_pushnumber(L, path.path()->duration());
    return 1;
}

int editor_scrub(lua_State* L) {
    Editor& editor = check_editor(L);  // self first: a wrong self is named before a wrong argument
    const lua_Number seconds = luaL_checknumber(L, 2);
    luaL_argcheck(L, std::isfinite(seconds), 2, "a finite time in seconds expected");
    editor.path().scrub(seconds);
    return 0;
}

int editor_time(lua_State* L) {
    lua_pushnumber(L, check_editor(L).path().time());
    return 1;
}

int editor_play(lua_State* L) {
    check_editor(L).path().play(lua_isnone(L, 2) || lua_toboolean(L, 2));
    return 0;
}

int editor_playing(lua_State* L) {
    lua_pushboolean(L, check_editor(L).path().playing());
    return 1;
}

int editor_save_path(lua_State* L) {
    Editor& editor = check_editor(L);
    const std::string file = luaL_checkstring(L, 2);
    return guarded(L, [&] {
        editor.path().save(file);
        return 0;
    });
}

int editor_load_path(lua_State* L) {
    Editor& editor = check_editor(L);
    const std::string file = luaL_checkstring(L, 2);
    return guarded(L, [&] {
        editor.path().load(file);
        return 0;
    });
}

// ---- bookmarks, console, screen ----

int editor_bookmark(lua_State* L) {  // ed:bookmark(name): the camera's pose, under that name
    check_editor(L).add_bookmark(luaL_checkstring(L, 2));
    return 0;
}

int editor_go(lua_State* L) {  // ed:go(name) → true, or false when there is no such bookmark
    lua_pushboolean(L, check_editor(L).go_to_bookmark(luaL_checkstring(L, 2)));
    return 1;
}

int editor_bookmarks(lua_State* L) {  // → { "name", … } in order
    const std::vector<Bookmark>& bookmarks = check_editor(L).bookmarks();
    lua_createtable(L, int(bookmarks.size()), 0);
    for (size_t i = 0; i < bookmarks.size(); ++i) {
        lua_pushstring(L, bookmarks[i].name.c_str());
        lua_rawseti(L, -2, lua_Integer(i + 1));
    }
    return 1;
}

int editor_console(lua_State* L) {  // ed:console(line) → what the console showed for it
    Editor& editor = check_editor(L);
    const std::string line = luaL_checkstring(L, 2);
    const size_t before = editor.console().log().size();
    editor.enter_console_line(line);
    lua_pushstring(L, editor.console().text(before).c_str());
    return 1;
}

// ed:screenshot([file.png]) → pixels, width, height: draws a frame and returns the window as shown,
// panels and all (a string of width × height × 4 bytes, 8-bit sRGB RGBA, rows top to bottom), and
// writes it to the PNG when given.
int editor_screenshot(lua_State* L) {
    Editor& editor = check_editor(L);
    const char* file = luaL_optstring(L, 2, nullptr);
    return guarded(L, [&] {
        int width = 0, height = 0;
        const std::vector<uint8_t> pixels = editor.screenshot(width, height);
        if (file) write_png_rgba8(pixels, width, height, file);
        lua_pushlstring(L, reinterpret_cast<const char*>(pixels.data()), pixels.size());
        lua_pushinteger(L, width);
        lua_pushinteger(L, height);
        return 3;
    });
}

// ed:stats() → { triangles, cubes, ui_ms, ui_build_ms, scene_ms, pick_ms, frames, converged,
// frames_unconverged } (the last two: FrameStats::frames_unconverged of the last frame)
int editor_stats(lua_State* L) {
    Editor& editor = check_editor(L);
    lua_createtable(L, 0, 9);
    lua_pushinteger(L, lua_Integer(editor.stats().triangles));
    lua_setfield(L, -2, "triangles");
    lua_pushinteger(L, lua_Integer(editor.stats().cubes));
    lua_setfield(L, -2, "cubes");
    lua_pushnumber(L, editor.timings().ui_ms);
    lua_setfield(L, -2, "ui_ms");
    lua_pushnumber(L, editor.timings().ui_build_ms);
    lua_setfield(L, -2, "ui_build_ms");
    lua_pushnumber(L, editor.timings().scene_ms);
    lua_setfield(L, -2, "scene_ms");
    lua_pushnumber(L, editor.timings().pick_ms);
    lua_setfield(L, -2, "pick_ms");
    lua_pushinteger(L, lua_Integer(editor.frames()));
    lua_setfield(L, -2, "frames");
    lua_pushboolean(L, editor.stats().frames_unconverged == 0);
    lua_setfield(L, -2, "converged");
    lua_pushinteger(L, lua_Integer(editor.stats().frames_unconverged));
    lua_setfield(L, -2, "frames_unconverged");
    return 1;
}

int editor_save(lua_State* L) {  // ed:save(file.lua): the scene script that reopens all of it
    Editor& editor = check_editor(L);
    const std::string file = luaL_checkstring(L, 2);
    return guarded(L, [&] {
        editor.save(file);
        return 0;
    });
}

// ed:click(x, y) → the node picked (now selected), the point and whether the hit is provisional (a
// stand-in for data still loading), or nil on the background: a click at pixel (x, y) of the window,
// from the top-left.
int editor_click(lua_State* L) {
    Editor& editor = check_editor(L);
    const double x = luaL_checknumber(L, 2), y = luaL_checknumber(L, 3);
    luaL_argcheck(L, x >= 0 && x < editor.camera().width, 2, "outside the window");
    luaL_argcheck(L, y >= 0 && y < editor.camera().height, 3, "outside the window");
    const std::optional<PickHit> hit = editor.click(x, y);
    if (!hit) return 0;
    push_node(L, editor.selected());
    lua::push_vec3(L, hit->point);
    lua_pushboolean(L, hit->provisional);
    return 3;
}

void push_reading(lua_State* L, const std::optional<GeoReading>& reading, const char* field) {
    if (!reading) return;
    lua::push_vec3(L, {reading->geo[0], reading->geo[1], reading->geo[2]});
    if (reading->above_ground) {
        lua_pushnumber(L, *reading->above_ground);
        lua_setfield(L, -2, "above_ground");
    }
    lua_setfield(L, -2, field);
}

// ed:geo() → {model=, crs=, camera={lon, lat, h, above_ground=}, cursor={...}}, or nil when no model in
// the scene is georeferenced: the Camera panel's read-out.
int editor_geo(lua_State* L) {
    const std::optional<Editor::GeoView> view = check_editor(L).geo_view();
    if (!view) return 0;
    lua_createtable(L, 0, 4);
    lua_pushstring(L, view->model.c_str());
    lua_setfield(L, -2, "model");
    lua_pushstring(L, view->crs.c_str());
    lua_setfield(L, -2, "crs");
    push_reading(L, view->camera, "camera");
    push_reading(L, view->cursor, "cursor");
    return 1;
}

// ed:embed(site[, {at = {lon, lat}, scale =, heading =} or {matrix =}]) → the new embedding (selected), in the terrain
// the selection belongs to; `at` by default the cursor's point on the ground
int editor_embed(lua_State* L) {
    Editor& editor = check_editor(L);
    const char* site = luaL_checkstring(L, 2);
    if (!lua_isnoneornil(L, 3)) lua::check_keys(L, 3, {"at", "scale", "heading", "matrix"});
    const SitePlacement placement = check_placement(L, 3, {});
    push_node(L, editor.embed_site(site, placement));  // C++ errors become Lua errors (lua::set_functions)
    return 1;
}

// ed:move{at =, scale =, heading =} or {matrix =} → the selected embedding's new node (selected); what is not given stays
int editor_move(lua_State* L) {
    Editor& editor = check_editor(L);
    luaL_checktype(L, 2, LUA_TTABLE);
    lua::check_keys(L, 2, {"at", "scale", "heading", "matrix"});
    push_node(L, editor.move_embedding(check_placement(L, 2, editor.embedding_placement())));
    return 1;
}

int editor_measure(lua_State* L) {  // ed:measure(on): exact split of the scene's and the panels' time
    check_editor(L).set_measure(lua_toboolean(L, 2));
    return 0;
}

int editor_panels(lua_State* L) {  // ed:panels([on]) → whether the panels are shown (Tab toggles them)
    Editor& editor = check_editor(L);
    if (!lua_isnone(L, 2)) editor.show_panels(lua_toboolean(L, 2));
    lua_pushboolean(L, editor.panels_shown());
    return 1;
}

const luaL_Reg kEditorMethods[] = {
    {"frame", editor_frame},       {"is_open", editor_is_open},       {"close", editor_close},
    {"select", editor_select},     {"selected", editor_selected},     {"add", editor_add},
    {"remove", editor_remove},     {"scene", editor_scene},           {"camera", editor_camera},
    {"add_key", editor_add_key},   {"move_key", editor_move_key},     {"remove_key", editor_remove_key},
    {"set_duration", editor_set_duration}, {"keys", editor_keys},     {"duration", editor_duration},
    {"scrub", editor_scrub},       {"time", editor_time},             {"play", editor_play},
    {"playing", editor_playing},   {"save_path", editor_save_path},   {"load_path", editor_load_path},
    {"bookmark", editor_bookmark}, {"go", editor_go},                 {"bookmarks", editor_bookmarks},
    {"console", editor_console},   {"screenshot", editor_screenshot}, {"stats", editor_stats},
    {"measure", editor_measure},   {"save", editor_save},             {"click", editor_click},
    {"panels", editor_panels},     {"geo", editor_geo},               {"embed", editor_embed},
    {"move", editor_move},
    {nullptr, nullptr}};

// strata.view([scene [, camera]]): without arguments, the scene script's globals (scene, camera,
// bookmarks, paths).
int view(lua_State* L) {
    SceneState state;
    if (!lua_isnoneornil(L, 1)) {
        state.scene = check_node(L, 1);
        if (!lua_isnoneornil(L, 2)) state.camera = check_camera(L, 2);
    }
    return guarded(L, [&] {
        if (!state.scene) state = read_scene_globals(L);
        open_editor(Runtime::of(L), std::move(state));
        push_editor(L);
        return 1;
    });
}

}  // namespace

void push_editor(lua_State* L) { lua_getfield(L, LUA_REGISTRYINDEX, kOpenEditor); }

std::shared_ptr<Editor> open_editor(Runtime& runtime, SceneState state) {
    lua_State* L = runtime.state();
    // One editor at a time: the previous one (open or closed) goes first.
    lua_getfield(L, LUA_REGISTRYINDEX, kOpenEditor);
    auto* previous = static_cast<std::shared_ptr<Editor>*>(luaL_testudata(L, -1, lua::type_name_of<Editor>()));
    lua_pop(L, 1);  // the registry keeps it
    if (previous && *previous && (*previous)->busy())
        throw std::runtime_error("strata.view cannot replace the open editor from its own console");
    Editor::checked_scene(state.scene);  // a scene it cannot open leaves the previous editor open
    if (previous) previous->reset();
    auto editor = std::make_shared<Editor>(runtime, std::move(state));
    // The Lua state owns it: it is destroyed when the state closes, before the GL context goes.
    lua::push_shared(L, editor);
    lua_setfield(L, LUA_REGISTRYINDEX, kOpenEditor);
    runtime.add_live_window([weak = std::weak_ptr<Editor>(editor)] {
        const std::shared_ptr<Editor> live = weak.lock();
        return live && live->frame();
    });
    return editor;
}

void register_editor(lua_State* L) {
    lua::register_type<Editor>(L, kEditorType, kEditorMethods);
    luaL_getsubtable(L, LUA_REGISTRYINDEX, LUA_LOADED_TABLE);
    lua_getfield(L, -1, "strata");
    const luaL_Reg functions[] = {{"view", view}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
    lua_pop(L, 2);
}

}  // namespace strata
