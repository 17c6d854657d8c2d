// strata.build{…}: `strata build` from Lua, with every option (one scan or the tiles of one, a memory
// ceiling; or a terrain from elevation rasters, with its frame, heights and imagery), a progress
// callback, and the statistics returned.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <lua.hpp>

#include "preprocess/build_inputs.h"
#include "preprocess/byte_size.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/mesh_io.h"
#include "preprocess/terrain_build.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"

namespace strata {

namespace {

constexpr lua_Integer kMaxThreads = 1024;  // far beyond any machine's cores; a typo of 1e9 threads is refused

// The options that build only meshes, and those that build only terrains (elevation rasters).
constexpr const char* kMeshOptions[] = {"levels", "block", "ratio", "sigma0", "error", "temp", "resume", "lock_boundary"};
constexpr const char* kTerrainOptions[] = {"crs",          "frame",   "elevation_unit", "fill_nodata",  "cube_cells",
                                           "height_tolerance", "texture", "texture_bands",  "texture_size"};

struct BuildJob {
    std::vector<std::string> inputs;  // files and @lists, as `strata build` takes them
    std::string output;
    BuildSettings settings;
    TerrainSettings terrain;
    std::string frame = "enu";  // enu, ecef or a CRS
    std::vector<std::string> mesh_options, terrain_options;  // those given, for refusing the wrong kind
    uint64_t memory_limit = 0;
    std::string limit_name;  // where the limit came from, for the refusal's message
};

// Which of `keys` the options table at `index` holds.
std::vector<std::string> given_options(lua_State* L, int index, std::span<const char* const> keys) {
    std::vector<std::string> given;
    for (const char* key : keys) {
        if (lua::get_option(L, index, key)) given.emplace_back(key);
        lua_pop(L, 1);
    }
    return given;
}

// The terrain options (strata build DEM's, as the CLI names them with dashes).
void check_terrain_options(lua_State* L, int index, BuildJob& job) {
    TerrainSettings& t = job.terrain;
    t.crs = lua::opt_string(L, index, "crs", "");
    job.frame = lua::opt_string(L, index, "frame", job.frame);
    t.elevation_unit = lua::opt_string(L, index, "elevation_unit", "");
    if (lua::get_option(L, index, "fill_nodata")) t.fill = lua::opt_float(L, index, "fill_nodata", 0);
    lua_pop(L, 1);
    t.cube_cells = uint32_t(lua::opt_integer_in(L, index, "cube_cells", t.cube_cells, 8, 256));
    if (lua::get_option(L, index, "height_tolerance")) {
        const double tolerance = lua::opt_number(L, index, "height_tolerance", 0);
        if (!(tolerance >= 0 && tolerance <= 1e6)) luaL_error(L, "option 'height_tolerance' must be metres from 0 to 1e6, got %f", tolerance);
        t.height_tolerance = tolerance;
    }
    lua_pop(L, 1);
    const std::string image = lua::opt_string(L, index, "texture", "");
    std::vector<int> bands;
    if (lua::get_option(L, index, "texture_bands")) {
        if (!lua_istable(L, -1)) luaL_error(L, "option 'texture_bands' must be a list of band numbers, got %s", luaL_typename(L, -1));
        const lua_Integer count = luaL_len(L, -1);
        if (count != 1 && count != 3) luaL_error(L, "option 'texture_bands': 1 band (grey) or 3 (red, green, blue), not %d", int(count));
        for (lua_Integer i = 1; i <= count; ++i) {
            lua_rawgeti(L, -1, i);
            int exact = 0;
            const lua_Integer band = lua_tointegerx(L, -1, &exact);
            if (!exact || band < 1 || band > 65535) luaL_error(L, "option 'texture_bands': item %d is not a band number (1 to 65535)", int(i));
            bands.push_back(int(band));
            lua_pop(L, 1);
        }
    }
    lua_pop(L, 1);
    const lua_Integer size = lua::opt_integer_in(L, index, "texture_size", 0, 0, 4096);
    if (size && !TextureLayout::valid_size(uint32_t(size))) luaL_error(L, "option 'texture_size': a power of two from 8 to 4096, not %d", int(size));
    if (!image.empty()) t.texture = TextureSettings{image, bands, uint32_t(size)};
    else if (!bands.empty() || size) luaL_error(L, "options 'texture_bands' and 'texture_size' need 'texture', the image to drape");
}

// `input`: a string (a file or an @list) or a list of strings (the tiles of one model).
std::vector<std::string> check_inputs(lua_State* L, int index) {
    std::vector<std::string> inputs;
    lua_getfield(L, index, "input");
    if (lua_type(L, -1) == LUA_TSTRING) {
        inputs.emplace_back(lua_tostring(L, -1));
    } else if (lua_istable(L, -1)) {
        const lua_Integer count = luaL_len(L, -1);
        for (lua_Integer i = 1; i <= count; ++i) {
            if (lua_rawgeti(L, -1, i) != LUA_TSTRING)
                luaL_error(L, "option 'input': item %d must be a string (a file name), got %s", int(i), luaL_typename(L, -1));
            inputs.emplace_back(lua_tostring(L, -1));
            lua_pop(L, 1);
        }
        if (inputs.empty()) luaL_error(L, "option 'input' is an empty list: name at least one file");
    } else if (!lua_isnil(L, -1)) {
        luaL_error(L, "option 'input' must be a string or a list of strings, got %s", luaL_typename(L, -1));
    }
    lua_pop(L, 1);
    for (const std::string& input : inputs)
        if (input.empty()) luaL_error(L, "option 'input': a file name is empty");
    return inputs;
}

// `memory`: a size as `--memory` takes it ("2G") or a number of bytes; default a quarter of RAM.
void check_memory_option(lua_State* L, int index, BuildJob& job) {
    job.memory_limit = default_memory_limit();
    job.limit_name = "the default memory, a quarter of physical memory";
    lua_getfield(L, index, "memory");
    const int type = lua_type(L, -1);
    if (type == LUA_TNUMBER) {
        lua_Integer bytes = lua::opt_integer_in(L, index, "memory", 1, 1, LUA_MAXINTEGER);
        job.memory_limit = uint64_t(bytes);
        job.limit_name = "memory = " + std::to_string(bytes);
    } else if (type == LUA_TSTRING) {
        const std::string text = lua_tostring(L, -1);
        std::string problem;
        try {
            job.memory_limit = parse_byte_size(text);
        } catch (const std::invalid_argument& e) {
            problem = e.what();
        }
        if (!problem.empty()) luaL_error(L, "option 'memory': %s", problem.c_str());
        job.limit_name = "memory = \"" + text + "\"";
    } else if (type != LUA_TNIL) {
        luaL_error(L, "option 'memory' must be a size such as \"2G\" or a number of bytes, got %s", luaL_typename(L, -1));
    }
    lua_pop(L, 1);
}

BuildJob check_job(lua_State* L, int index) {
    luaL_checktype(L, index, LUA_TTABLE);
    lua::check_keys(L, index, {"input", "output", "levels", "block", "ratio", "sigma0", "error", "threads", "memory", "temp", "resume",
                               "lock_boundary", "on_progress", "crs", "frame", "elevation_unit", "fill_nodata", "cube_cells", "height_tolerance",
                               "texture", "texture_bands", "texture_size"});
    BuildJob job;
    job.mesh_options = given_options(L, index, kMeshOptions);
    job.terrain_options = given_options(L, index, kTerrainOptions);
    job.inputs = check_inputs(L, index);
    job.output = lua::opt_string(L, index, "output", "");
    if (job.inputs.empty()) luaL_error(L, "option 'input' (the scan to build) is required");
    if (job.output.empty() && job.inputs.size() > 1)
        luaL_error(L, "option 'output' is required when 'input' names several files");
    if (job.output.empty()) {
        const std::string& only = job.inputs.front();
        job.output = std::filesystem::path(only[0] == '@' ? only.substr(1) : only).replace_extension(".hlod").string();
    }
    check_memory_option(L, index, job);
    // The builder checks what the values mean; here only that they fit its types.
    job.settings.levels = int(lua::opt_integer_in(L, index, "levels", -1, -1, INT_MAX));
    job.settings.block = int(lua::opt_integer_in(L, index, "block", job.settings.block, 1, INT_MAX));
    job.settings.ratio = lua::opt_float(L, index, "ratio", job.settings.ratio);
    job.settings.sigma0 = lua::opt_float(L, index, "sigma0", job.settings.sigma0);
    job.settings.error = lua::opt_float(L, index, "error", job.settings.error);
    job.settings.threads = int(lua::opt_integer_in(L, index, "threads", 0, 0, kMaxThreads));
    job.settings.temp_dir = lua::opt_string(L, index, "temp", "");
    job.settings.resume = lua::opt_boolean(L, index, "resume", false);
    job.settings.lock_boundary = lua::opt_boolean(L, index, "lock_boundary", false);
    check_terrain_options(L, index, job);
    job.terrain.threads = job.settings.threads;
    return job;
}

// A model from a scan (or its tiles), within the job's memory and temporary disk: refuses the terrain
// options. `warnings`: what the reader read past; `estimate`: the memory the build was expected to take.
BuildReport build_mesh_job(const BuildJob& job, const std::vector<std::filesystem::path>& files, const Progress& progress,
                           std::vector<std::string>& warnings, MemoryEstimate& estimate) {
    if (!job.terrain_options.empty())
        throw InputError("option '" + job.terrain_options.front() + "' builds terrains from elevation rasters; " + files.front().string() +
                         " is a mesh");
    BuildSettings settings = job.settings;
    settings.memory = job.memory_limit;
    check_settings(settings);
    estimate = estimate_build(files, job.memory_limit);
    check_memory(estimate, job.memory_limit, job.limit_name);
    check_temp_disk(estimate, temp_folder(job.output, job.settings.temp_dir),
                    settings.resume ? leftover_bytes(job.output, job.settings.temp_dir) : 0);
    return build_hlod(input_from_files(files, job.memory_limit, progress, warnings), files, job.output, settings,
                      source_name(job.inputs, files.size()), progress);
}

// A terrain from elevation rasters (the CLI's run_terrain): refuses the mesh options.
BuildReport build_terrain_job(const BuildJob& job, const std::vector<std::filesystem::path>& files, const Progress& progress) {
    if (!job.mesh_options.empty())
        throw InputError("option '" + job.mesh_options.front() + "' builds meshes; " + files.front().string() + " is an elevation raster");
    TerrainSettings settings = job.terrain;
    settings.memory = job.memory_limit;
    set_frame(settings, job.frame);
    return build_terrain(files, job.output, settings, source_name(job.inputs, files.size()), progress);
}

// What the build's worker reports, for the Lua thread to pass on.
struct Shared {
    std::mutex mutex;
    std::condition_variable changed;
    std::string stage, unit;
    double done = 0, total = 0;
    bool fresh = false, finished = false;
    // The first report wakes the Lua thread at once and waits until on_progress has had it, so that a
    // script can cancel before any work, however quick the build.
    bool first_report = true, first_delivered = false;
    bool wake = false;
};

// Runs the build on a worker thread while this one (the only one that may touch Lua) calls
// on_progress with the latest figures, ten times a second at most. on_progress returning false, or
// raising an error (any value: it is reported as text), cancels the build, which then leaves no output.
int build(lua_State* L) {
    const BuildJob job = check_job(L, 1);
    const bool has_callback = lua::get_option(L, 1, "on_progress");
    if (has_callback && !lua_isfunction(L, -1))
        return luaL_error(L, "option 'on_progress' must be a function, got %s", luaL_typename(L, -1));
    const int callback = lua_gettop(L);

    Shared shared;
    std::atomic<bool> cancel{false};
    Progress progress{[&](std::string_view stage, double done, double total, std::string_view unit) {
                          std::unique_lock lock(shared.mutex);
                          shared.stage = stage, shared.unit = unit, shared.done = done, shared.total = total;
                          shared.fresh = true;
                          if (shared.first_report) {
                              shared.first_report = false;
                              shared.wake = true;
                              shared.changed.notify_all();
                              if (has_callback) shared.changed.wait(lock, [&] { return shared.first_delivered; });
                          }
                      },
                      &cancel};
    BuildReport report;
    std::vector<std::string> warnings;  // what the reader read past rather than refused
    std::string error;
    bool cancelled = false;
    const auto start = std::chrono::steady_clock::now();
    uint64_t triangles = 0;
    MemoryEstimate estimate;
    std::thread worker([&] {
        try {
            const std::vector<std::filesystem::path> files = expand_inputs(job.inputs);
            report = std::all_of(files.begin(), files.end(), is_elevation_raster) ? build_terrain_job(job, files, progress)
                                                                                 : build_mesh_job(job, files, progress, warnings, estimate);
            triangles = report.input_triangles;
        } catch (const Cancelled&) {
            cancelled = true;
        } catch (const std::exception& e) {
            error = e.what();
        }
        std::lock_guard lock(shared.mutex);
        shared.finished = true;
        shared.changed.notify_all();
    });
    // A Lua error while passing figures on (out of memory) unwinds this function: the build is
    // cancelled and waited for first, as a joinable std::thread destroyed would end the process.
    struct JoinOnUnwind {
        std::thread& worker;
        std::atomic<bool>& cancel;
        Shared& shared;
        ~JoinOnUnwind() {
            if (!worker.joinable()) return;
            cancel = true;
            {
                std::lock_guard lock(shared.mutex);
                shared.first_delivered = true;  // a worker waiting on its first report goes on, to stop
                shared.changed.notify_all();
            }
            worker.join();
        }
    } join_on_unwind{worker, cancel, shared};

    // Passes the latest figures to on_progress; called with the mutex held, released around the call.
    std::string callback_error;
    auto deliver = [&](std::unique_lock<std::mutex>& lock) {
        if (!has_callback || !shared.fresh || !callback_error.empty()) return;
        shared.fresh = false;
        const std::string stage = shared.stage, unit = shared.unit;
        const double done = shared.done, total = shared.total;
        lock.unlock();
        lua_pushvalue(L, callback);
        lua_pushstring(L, stage.c_str());
        lua_pushnumber(L, done);
        lua_pushnumber(L, total);
        lua_pushstring(L, unit.c_str());
        if (lua_pcall(L, 4, 1, 0) != LUA_OK) {
            callback_error = lua::error_text(L, -1);
            cancel = true;
        } else if (lua_isboolean(L, -1) && !lua_toboolean(L, -1)) {
            cancel = true;
        }
        lua_pop(L, 1);
        lock.lock();
        shared.first_delivered = true;
        shared.changed.notify_all();
    };
    {
        std::unique_lock lock(shared.mutex);
        while (!shared.finished) {
            shared.changed.wait_for(lock, std::chrono::milliseconds(100), [&] { return shared.finished || shared.wake; });
            shared.wake = false;
            deliver(lock);
        }
        deliver(lock);  // the last report, also for builds quicker than one interval
    }
    worker.join();
    if (!callback_error.empty()) return luaL_error(L, "on_progress: %s", callback_error.c_str());
    if (!error.empty()) return luaL_error(L, "%s", error.c_str());
    if (cancelled)
        return luaL_error(L, "build of %s cancelled; %s was not written", job.inputs.front().c_str(), job.output.c_str());

    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    lua_createtable(L, 0, 11);
    lua_pushstring(L, job.output.c_str());
    lua_setfield(L, -2, "output");
    lua_pushinteger(L, report.max_level + 1);
    lua_setfield(L, -2, "levels");
    lua_pushinteger(L, lua_Integer(triangles));
    lua_setfield(L, -2, "triangles");
    lua_pushnumber(L, report.sigma0);
    lua_setfield(L, -2, "sigma0");
    lua_pushnumber(L, report.error_q);
    lua_setfield(L, -2, "error_q");
    lua_pushinteger(L, lua_Integer(report.output_bytes));
    lua_setfield(L, -2, "bytes");
    lua_pushnumber(L, seconds);
    lua_setfield(L, -2, "seconds");
    lua_pushinteger(L, lua_Integer(estimate.bytes));
    lua_setfield(L, -2, "memory_estimate");
    lua_pushboolean(L, report.resumed || report.already_complete);
    lua_setfield(L, -2, "resumed");
    if (job.settings.lock_boundary && !report.already_complete) {
        lua_pushinteger(L, lua_Integer(report.boundary_points));
        lua_setfield(L, -2, "boundary_points");
    }
    if (report.height_quantum > 0) {  // a terrain
        lua_pushnumber(L, report.height_quantum);
        lua_setfield(L, -2, "height_quantum");
        lua_pushinteger(L, report.texture_size);
        lua_setfield(L, -2, "texture_size");
    }
    lua_createtable(L, int(report.levels.size()), 0);
    for (size_t i = 0; i < report.levels.size(); ++i) {
        const LevelStats& l = report.levels[i];
        lua_createtable(L, 0, 4);
        lua_pushinteger(L, l.level);
        lua_setfield(L, -2, "level");
        lua_pushinteger(L, lua_Integer(l.cubes));
        lua_setfield(L, -2, "cubes");
        lua_pushinteger(L, lua_Integer(l.triangles));
        lua_setfield(L, -2, "triangles");
        lua_pushinteger(L, lua_Integer(l.bytes));
        lua_setfield(L, -2, "bytes");
        lua_rawseti(L, -2, lua_Integer(i + 1));
    }
    lua_setfield(L, -2, "per_level");
    lua_createtable(L, int(warnings.size()), 0);
    for (size_t i = 0; i < warnings.size(); ++i) {
        lua_pushstring(L, warnings[i].c_str());
        lua_rawseti(L, -2, lua_Integer(i + 1));
    }
    lua_setfield(L, -2, "warnings");
    for (const std::string& warning : warnings) std::fprintf(stderr, "strata.build: warning: %s\n", warning.c_str());
    for (const std::string& note : report.notes) std::fprintf(stderr, "strata.build: note: %s\n", note.c_str());
    return 1;
}

}  // namespace

void register_build(lua_State* L) {
    const luaL_Reg functions[] = {{"build", build}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata
