// Files for batch jobs: strata.files(folder[, extensions]) lists a folder's files (sorted, optionally
// only some extensions), strata.modified(path) gives a file's modification time (nil if absent), so a
// script can skip outputs newer than their inputs; strata.mkdir(path) makes a folder and its parents.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include <lua.hpp>

#include "scripting/lua_util.h"
#include "scripting/runtime.h"

namespace strata {

namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return s;
}

int files(lua_State* L) {
    const fs::path folder = luaL_checkstring(L, 1);
    std::vector<std::string> extensions;  // ".ply", lower case
    if (!lua_isnoneornil(L, 2)) {
        luaL_checktype(L, 2, LUA_TTABLE);
        for (lua_Integer i = 1; i <= lua_Integer(lua_rawlen(L, 2)); ++i) {
            lua_rawgeti(L, 2, i);
            std::string e = lower(luaL_checkstring(L, -1));
            extensions.push_back(e.empty() || e[0] == '.' ? e : "." + e);
            lua_pop(L, 1);
        }
    }
    std::vector<std::string> found;
    std::error_code error;
    for (const fs::directory_entry& entry : fs::directory_iterator(folder, error)) {
        if (!entry.is_regular_file()) continue;
        const std::string extension = lower(entry.path().extension().string());
        if (extensions.empty() || std::find(extensions.begin(), extensions.end(), extension) != extensions.end())
            found.push_back(entry.path().string());
    }
    if (error) return luaL_error(L, "cannot list %s: %s", folder.c_str(), error.message().c_str());
    std::sort(found.begin(), found.end());
    lua_createtable(L, int(found.size()), 0);
    for (size_t i = 0; i < found.size(); ++i) {
        lua_pushstring(L, found[i].c_str());
        lua_rawseti(L, -2, lua_Integer(i + 1));
    }
    return 1;
}

int modified(lua_State* L) {
    std::error_code error;
    const fs::file_time_type time = fs::last_write_time(luaL_checkstring(L, 1), error);
    if (error) return 0;
    // file_clock → system_clock (GCC 12 has no clock_cast): the same instant, measured from now on each.
    const auto system = std::chrono::system_clock::now() + (time - fs::file_time_type::clock::now());
    lua_pushnumber(L, std::chrono::duration<double>(system.time_since_epoch()).count());
    return 1;
}

int make_folder(lua_State* L) {
    std::error_code error;
    fs::create_directories(luaL_checkstring(L, 1), error);
    if (error) return luaL_error(L, "cannot make folder %s: %s", lua_tostring(L, 1), error.message().c_str());
    return 0;
}

}  // namespace

void register_files(lua_State* L) {
    const luaL_Reg functions[] = {{"files", files}, {"modified", modified}, {"mkdir", make_folder}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata
