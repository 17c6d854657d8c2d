// strata.render(scene, camera, {…}) → a frame (type "strata.Frame"): its pixels, its statistics, and
// frame:write(path, {…}) to PNG or OpenEXR. With `strata run --window` each render is also shown.
#include <cmath>
#include <algorithm>
#include <string>
#include <thread>

#include <lua.hpp>

#include "engine/gl/framebuffer.h"
#include "engine/io/image.h"
#include "engine/io/image_writer.h"
#include "engine/render/present.h"
#include "engine/render/renderer.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"
#include "scripting/wrap_camera.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

constexpr const char* kFrameType = "strata.Frame";

constexpr lua_Integer kMaxThreads = 1024;

struct Frame {
    std::shared_ptr<const Image> image;  // shared with the background writer
    FrameStats stats;
};

size_t pixel_bytes(const Image& image) {
    return sizeof(float) * (image.rgba.size() + image.depth.size() + image.normals.size() + image.level.size()) +
           sizeof(uint32_t) * image.node_id.size();
}

// Channel names from a string ("RGBA,Z") or a list ({"RGBA", "Z"}) at the top of the stack.
ImageChannels channels_at_top(lua_State* L, const char* option) {
    std::string names;
    if (lua_type(L, -1) == LUA_TSTRING) {
        names = lua_tostring(L, -1);
    } else if (lua_istable(L, -1)) {
        for (lua_Integer i = 1; i <= lua_Integer(lua_rawlen(L, -1)); ++i) {
            lua_rawgeti(L, -1, i);
            if (lua_type(L, -1) != LUA_TSTRING) luaL_error(L, "option '%s' must list channel names", option);
            names += std::string(names.empty() ? "" : ",") + lua_tostring(L, -1);
            lua_pop(L, 1);
        }
    } else {
        luaL_error(L, "option '%s' must be a string or a list of channel names, got %s", option, luaL_typename(L, -1));
    }
    try {
        return parse_channels(names);
    } catch (const std::exception& e) {
        luaL_error(L, "option '%s': %s", option, e.what());
    }
    return {};
}

int render(lua_State* L) {
    const NodePtr& scene = check_node(L, 1);
    const std::shared_ptr<Camera>& camera = check_camera(L, 2);
    lua::check_keys(L, 3, {"samples", "channels", "background", "culling", "gpu_time", "full_detail"});
    ImageChannels channels = ImageChannel::rgba;
    if (lua::get_option(L, 3, "channels")) channels = channels_at_top(L, "channels");
    lua_pop(L, 1);
    RenderSettings settings;
    if (lua::get_option(L, 3, "background")) {
        luaL_checktype(L, -1, LUA_TTABLE);
        for (int i = 0; i < 4; ++i) {
            lua_rawgeti(L, -1, i + 1);
            settings.background[i] =
                lua::to_float(L, lua_isnil(L, -1) ? (i == 3 ? 1.0 : 0.0) : luaL_checknumber(L, -1), "option 'background'");
            lua_pop(L, 1);
        }
    }
    lua_pop(L, 1);
    settings.frustum_culling = lua::opt_boolean(L, 3, "culling", true);
    settings.measure_gpu_time = lua::opt_boolean(L, 3, "gpu_time", false);
    // full_detail (default true): draw once every cube the view selects is resident, so that the frame
    // does not depend on the cache; { timeout = S } fails after S seconds; false draws what is resident.
    settings.full_detail = true;
    if (lua::get_option(L, 3, "full_detail")) {
        if (lua_istable(L, -1)) {
            lua::check_keys(L, lua_gettop(L), {"timeout"});
            settings.full_detail_timeout = lua::opt_number(L, lua_gettop(L), "timeout", 0);
            if (!(settings.full_detail_timeout > 0)) return luaL_error(L, "option 'full_detail': timeout must be a number of seconds above 0");
        } else {
            luaL_argexpected(L, lua_isboolean(L, -1), 3, "full_detail: a boolean or { timeout = seconds }");
            settings.full_detail = lua_toboolean(L, -1);
        }
    }
    lua_pop(L, 1);
    const lua_Integer samples = lua::opt_integer(L, 3, "samples", 4);
    if (samples != 1 && samples != 2 && samples != 4 && samples != 8) return luaL_error(L, "option 'samples' must be 1, 2, 4 or 8");

    Runtime& runtime = Runtime::of(L);
    settings.upcoming = runtime.upcoming_poses();
    auto frame = std::make_shared<Frame>();
    try {
        Renderer& renderer = runtime.renderer();
        gl::Framebuffer target({.width = camera->width, .height = camera->height, .samples = int(samples),
                                .normals = channels.contains(ImageChannel::normals),
                                .level = channels.contains(ImageChannel::level),
                                .node_id = channels.contains(ImageChannel::node_id)});
        frame->stats = renderer.render(*scene, *camera, target, settings);
        frame->image = std::make_shared<const Image>(renderer.read_image(target));
        if (runtime.options().window) {
            present(target, runtime.context());
            runtime.context().poll_events();
        }
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    lua::push_shared(L, frame);
    lua::account_external(L, pixel_bytes(*frame->image));
    return 1;
}

Frame& check_frame(lua_State* L, int index) { return *lua::check_shared<Frame>(L, index); }

int frame_write(lua_State* L) {
    const Frame& frame = check_frame(L, 1);
    const std::string path = luaL_checkstring(L, 2);
    lua::check_keys(L, 3, {"channels", "compression", "threads", "async"});
    const bool png = path.size() > 4 && path.substr(path.size() - 4) == ".png";
    const bool exr = path.size() > 4 && path.substr(path.size() - 4) == ".exr";
    if (!png && !exr) return luaL_argerror(L, 2, "the file name must end in .png or .exr");
    ImageChannels channels = frame.image->planes();
    if (lua::get_option(L, 3, "channels")) channels = channels_at_top(L, "channels");
    lua_pop(L, 1);
    const bool async = lua::opt_boolean(L, 3, "async", false);
    try {
        ExrOptions options;
        options.compression = parse_exr_compression(lua::opt_string(L, 3, "compression", "zip"));
        // Compression on OpenEXR's worker threads, one per core unless told otherwise.
        options.worker_threads =
            int(lua::opt_integer_in(L, 3, "threads", std::max(1u, std::thread::hardware_concurrency()), 1, kMaxThreads));
        for (ImageChannel c : {ImageChannel::depth, ImageChannel::normals, ImageChannel::level, ImageChannel::node_id})
            if (exr && channels.contains(c) && !frame.image->has(c))
                throw std::invalid_argument("the frame has no " + channel_name(c) + " channel: render it with channels = \"..." +
                                            channel_name(c) + "\"");
        if (async) Runtime::of(L).writer().write(frame.image, path, channels, options);
        else if (png) write_png(*frame.image, path);
        else write_exr(*frame.image, path, channels, options);
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    lua_settop(L, 1);
    return 1;
}

int frame_size(lua_State* L) {
    const Frame& frame = check_frame(L, 1);
    lua_pushinteger(L, frame.image->width);
    lua_pushinteger(L, frame.image->height);
    return 2;
}

// frame:pixel(x, y) → r, g, b, a (linear), depth, node id; x, y from 0 at the top left.
int frame_pixel(lua_State* L) {
    const Frame& frame = check_frame(L, 1);
    const lua_Integer x = luaL_checkinteger(L, 2), y = luaL_checkinteger(L, 3);
    const Image& image = *frame.image;
    luaL_argcheck(L, x >= 0 && x < image.width, 2, "outside the image");
    luaL_argcheck(L, y >= 0 && y < image.height, 3, "outside the image");
    const size_t p = size_t(y) * image.width + size_t(x);
    for (int c = 0; c < 4; ++c) lua_pushnumber(L, image.rgba[4 * p + c]);
    lua_pushnumber(L, image.depth.empty() ? HUGE_VAL : image.depth[p]);
    lua_pushinteger(L, image.node_id.empty() ? 0 : image.node_id[p]);
    return 6;
}

int frame_stats(lua_State* L) {
    const FrameStats& s = check_frame(L, 1).stats;
    const std::pair<const char*, double> fields[] = {
        {"triangles", double(s.triangles)}, {"cubes", double(s.cubes)}, {"draw_calls", double(s.draw_calls)},
        {"draw_items", double(s.draw_items)}, {"nodes_culled", double(s.nodes_culled)}, {"cull_ms", s.cull_ms},
        {"draw_ms", s.draw_ms}, {"gpu_ms", s.gpu_ms}, {"bytes_resident", double(s.bytes_resident)},
        {"stand_ins", double(s.stand_ins)}, {"loads_pending", double(s.loads_pending)},
        {"memory_resident", double(s.memory_resident)}, {"loaded", double(s.loaded)}, {"evicted", double(s.evicted)},
        {"fading", double(s.fading)}, {"memory_resident_gpu", double(s.memory_resident_gpu)},
        {"memory_tables", double(s.memory_tables)},
        {"frames_unconverged", double(s.frames_unconverged)}};
    lua::push_numbers(L, fields);
    lua_pushboolean(L, s.frames_unconverged == 0);
    lua_setfield(L, -2, "converged");
    return 1;
}

// frame:release() (and `local f <close> = strata.render(…)`): frees the pixels now rather than when
// the collector gets to the frame; the frame's methods then raise "strata.Frame has been released".
const luaL_Reg kMethods[] = {{"write", frame_write},   {"size", frame_size}, {"pixel", frame_pixel},
                             {"stats", frame_stats},   {"release", lua::release_shared<Frame>},
                             {nullptr, nullptr}};

// strata.flush(): waits for frames written with { async = true }; raises the first that failed.
int flush(lua_State* L) {
    try {
        Runtime::of(L).writer().flush();
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 0;
}

}  // namespace

void register_render(lua_State* L) {
    const luaL_Reg metamethods[] = {{"__close", lua::release_shared<Frame>}, {nullptr, nullptr}};
    lua::register_type<Frame>(L, kFrameType, kMethods, metamethods);
    const luaL_Reg functions[] = {{"render", render}, {"flush", flush}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata
