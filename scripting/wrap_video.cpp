// strata.video{…}: a numbered frame sequence (PNG frames written by frame:write) encoded to an MP4 by
// Debian's ffmpeg, with the frame rate and quality given; a clear error when ffmpeg is missing.
#include <climits>

#include <lua.hpp>

#include "engine/io/video.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"

namespace strata {

namespace {

int video(lua_State* L) {
    luaL_checktype(L, 1, LUA_TTABLE);
    lua::check_keys(L, 1, {"frames", "output", "fps", "first", "quality"});
    VideoOptions options;
    options.frames = lua::opt_string(L, 1, "frames", "");
    options.output = lua::opt_string(L, 1, "output", "");
    if (options.frames.empty() || options.output.empty())
        return luaL_error(L, "strata.video needs 'frames' (a pattern such as \"out/f%%05d.png\") and 'output' (an .mp4)");
    options.fps = lua::opt_number(L, 1, "fps", options.fps);
    options.first_frame = int(lua::opt_integer_in(L, 1, "first", options.first_frame, 0, INT_MAX));
    options.quality = int(lua::opt_integer_in(L, 1, "quality", options.quality, 0, 51));
    try {
        encode_video(options);
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 0;
}

}  // namespace

void register_video(lua_State* L) {
    const luaL_Reg functions[] = {{"video", video}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata
