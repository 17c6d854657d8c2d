#include "scripting/runtime.h"

#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

#include <lua.hpp>

#include "engine/gl/context.h"
#include "engine/io/image_writer.h"
#include "engine/render/renderer.h"
#include "scripting/lua_util.h"

namespace strata {

namespace {

int open_strata(lua_State* L) {
    lua_newtable(L);
    register_scene(L);
    register_camera(L);
    register_render(L);
    register_build(L);
    register_video(L);
    register_measure(L);
    register_memory(L);
    register_files(L);
    register_path(L);
    register_pick(L);
    register_scene_script(L);
    return 1;
}

// The message handler: the error with a traceback from where it was raised.
int traceback(lua_State* L) {
    const std::string message = lua::error_text(L, 1);
    luaL_traceback(L, L, message.c_str(), 1);
    return 1;
}

// The debug library, less what lets a script reach memory as something it is not: the registry
// (whose metatables the type checks trust), metatables of userdata, upvalues of C functions (the
// guarded bindings' real functions, the standard iterators' unchecked state) and locals of C
// functions. Tracebacks, hooks, getinfo and the rest stay.
const char* const kRestrictDebug = R"lua(
local debug, type, error = debug, type, error
local getinfo, setmetatable, getupvalue, setupvalue, setlocal =
    debug.getinfo, debug.setmetatable, debug.getupvalue, debug.setupvalue, debug.setlocal
local function refuse(what) error("debug." .. what .. " is not available in strata (it could corrupt memory)", 3) end
debug.getregistry = function() refuse("getregistry") end
debug.setmetatable = function(value, metatable)
    if type(value) == "userdata" then refuse("setmetatable on a userdata") end
    return setmetatable(value, metatable)
end
local function lua_function(f, what)
    if type(f) == "function" and getinfo(f, "S").what == "C" then refuse(what .. " of a C function") end
end
debug.getupvalue = function(f, n) lua_function(f, "getupvalue") return getupvalue(f, n) end
debug.setupvalue = function(f, n, v) lua_function(f, "setupvalue") return setupvalue(f, n, v) end
debug.setlocal = function(...)
    local thread = ...
    local info
    if type(thread) == "thread" then info = getinfo(thread, select(2, ...), "S")
    elseif type(thread) == "number" then info = getinfo(thread + 1, "S") end
    if info and info.what == "C" then refuse("setlocal of a C function") end
    if type(thread) == "number" then return setlocal(thread + 1, select(2, ...)) end
    return setlocal(...)
end
)lua";

// print, as Lua's own, but through the runtime's output (the editor's console captures it).
int print(lua_State* L) {
    std::string line;
    for (int i = 1; i <= lua_gettop(L); ++i) {
        if (i > 1) line += '\t';
        size_t length = 0;
        const char* text = luaL_tolstring(L, i, &length);
        line.append(text, length);
        lua_pop(L, 1);
    }
    line += '\n';
    Runtime::of(L).write_output(line, false);
    return 0;
}

}  // namespace

Runtime::Runtime(RuntimeOptions options) : options_(options), L_(luaL_newstate()) {
    if (!L_) throw std::runtime_error("cannot create a Lua state: out of memory");
    *static_cast<Runtime**>(lua_getextraspace(L_)) = this;
    luaL_openlibs(L_);
    luaL_requiref(L_, "strata", open_strata, 1);  // package.loaded.strata, and the global
    lua_pop(L_, 1);
    lua_register(L_, "print", print);
    if (luaL_dostring(L_, kRestrictDebug) != LUA_OK) throw std::logic_error(lua::error_text(L_, -1));
}

Runtime::~Runtime() {
    lua_close(L_);  // first: userdata finalizers may still need the renderer and its context
    renderer_.reset();
    context_.reset();
}

Runtime& Runtime::of(lua_State* L) { return **static_cast<Runtime**>(lua_getextraspace(L)); }

gl::Context& Runtime::context() {
    if (!context_)
        context_ = options_.window ? gl::create_window_context("strata run", 1280, 720) : gl::create_headless_context();
    return *context_;
}

gl::Context& Runtime::window_context() {
    if (context_ && context_->window()) return *context_;
    renderer_.reset();  // its GPU objects belong to the context going away
    context_.reset();
    context_ = gl::create_window_context("strata", 1280, 720);
    return *context_;
}

void Runtime::write_output(std::string_view text, bool error) const {
    if (sink_) return sink_(text, error);
    if (error) std::fflush(stdout);  // what was printed before comes before the error
    std::fwrite(text.data(), 1, text.size(), error ? stderr : stdout);
}

void Runtime::pump_live_windows() {
    std::erase_if(live_windows_, [](const std::function<bool()>& frame) { return !frame(); });
}

ImageWriter& Runtime::writer() {
    if (!writer_) writer_ = std::make_unique<ImageWriter>();
    return *writer_;
}

Renderer& Runtime::renderer() {
    context();
    if (!renderer_) renderer_ = std::make_unique<Renderer>();
    return *renderer_;
}

bool Runtime::protected_call(int arguments, int results) {
    const int handler = lua_gettop(L_) - arguments;
    lua_pushcfunction(L_, traceback);
    lua_insert(L_, handler);
    const int status = lua_pcall(L_, arguments, results, handler);
    lua_remove(L_, handler);
    if (status == LUA_OK) return true;
    // A message, or whatever was raised (an error object, or nothing readable when a C++ exception
    // unwound through Lua): never a null string.
    write_output(lua::error_text(L_, -1) + "\n", true);
    lua_pop(L_, 1);
    return false;
}

int Runtime::call(int arguments) {
    const bool ok = protected_call(arguments, 0);
    // Frames still being written in the background are part of the script's work: wait for them, and
    // a frame that could not be written fails the run.
    if (writer_) {
        try {
            writer_->flush();
        } catch (const std::exception& e) {
            std::fprintf(stderr, "%s\n", e.what());
            return 1;
        }
    }
    return ok ? 0 : 1;
}

int Runtime::run_file(const std::filesystem::path& script, const std::vector<std::string>& args) {
    // `require` finds modules beside the script, wherever the script is started from.
    const std::string folder = script.parent_path().empty() ? "." : script.parent_path().string();
    lua_getglobal(L_, "package");
    lua_pushfstring(L_, "%s/?.lua;%s/?/init.lua;", folder.c_str(), folder.c_str());
    lua_getfield(L_, -2, "path");
    lua_concat(L_, 2);
    lua_setfield(L_, -2, "path");
    lua_pop(L_, 1);

    lua_createtable(L_, int(args.size()), 1);
    lua_pushstring(L_, script.c_str());
    lua_rawseti(L_, -2, 0);
    for (size_t i = 0; i < args.size(); ++i) {
        lua_pushstring(L_, args[i].c_str());
        lua_rawseti(L_, -2, lua_Integer(i + 1));
    }
    lua_setglobal(L_, "arg");

    if (luaL_loadfile(L_, script.c_str()) != LUA_OK) {
        std::fprintf(stderr, "%s\n", lua::error_text(L_, -1).c_str());  // "cannot open x.lua" or "x.lua:3: syntax error"
        lua_pop(L_, 1);
        return 1;
    }
    for (const std::string& a : args) lua_pushstring(L_, a.c_str());  // also as `...`
    return call(int(args.size()));
}

int Runtime::run_string(const std::string& source, const std::string& name) {
    if (luaL_loadbuffer(L_, source.data(), source.size(), ("=" + name).c_str()) != LUA_OK) {
        std::fprintf(stderr, "%s\n", lua::error_text(L_, -1).c_str());
        lua_pop(L_, 1);
        return 1;
    }
    return call(0);
}

}  // namespace strata
