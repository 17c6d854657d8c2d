// strata.build{…}: `strata build` from Lua, with every option (one scan or the tiles of one, a memory
// ceiling), a progress callback, and the statistics returned.
#include <atomic>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <lua.hpp>

#include "preprocess/build_inputs.h"
#include "preprocess/byte_size.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/mesh_io.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"

namespace strata {

namespace {

constexpr lua_Integer kMaxThreads = 1024;  // far beyond any machine's cores; a typo of 1e9 threads is refused

struct BuildJob {
    std::vector<std::string> inputs;  // files and @lists, as `strata build` takes them
    std::string output;
    BuildSettings settings;
    uint64_t memory_limit = 0;
    std::string limit_name;  // where the limit came from, for the refusal's message
};

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
    lua::check_keys(L, index,
                    {"input", "output", "levels", "block", "ratio", "sigma0", "error", "threads", "memory", "temp", "resume", "on_progress"});
    BuildJob job;
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
    return job;
}

// What the build's worker reports, for the Lua thread to pass on.
struct Shared {
    std::mutex mutex;
    std::condition_variable changed;
    std::string stage, unit;
    double done = 0, total = 0;
    bool fresh = false, finished = false;
    bool first_report = true;  // the first report wakes the Lua thread at once: a callback can cancel early
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
                          std::lock_guard lock(shared.mutex);
                          shared.stage = stage, shared.unit = unit, shared.done = done, shared.total = total;
                          shared.fresh = true;
                          if (shared.first_report) {
                              shared.first_report = false;
                              shared.wake = true;
                              shared.changed.notify_all();
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
            BuildSettings settings = job.settings;
            settings.memory = job.memory_limit;
            check_settings(settings);
            estimate = estimate_build(files, job.memory_limit);
            check_memory(estimate, job.memory_limit, job.limit_name);
            check_temp_disk(estimate, temp_folder(job.output, job.settings.temp_dir),
                            settings.resume ? leftover_bytes(job.output, job.settings.temp_dir) : 0);
            report = build_hlod(input_from_files(files, job.memory_limit, progress, warnings), files, job.output, settings,
                                source_name(job.inputs, files.size()), progress);
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
        ~JoinOnUnwind() {
            if (!worker.joinable()) return;
            cancel = true;
            worker.join();
        }
    } join_on_unwind{worker, cancel};

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
