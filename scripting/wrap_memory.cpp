// The streaming budget from Lua (DESIGN.md §7, engine/stream): strata.memory{ total = "2G" } sets the
// hard cap on the bytes every streamed model's geometry takes in CPU and GPU memory together (a size
// in the build's grammar, or a number of bytes; at least 16M), gpu = "1G" a cap on the GPU's share
// alone (false: none), and strata.memory() returns the limits and what is held: { total, gpu,
// resident, gpu_resident, reserved, tables, gpu_tables, peak, cubes, in_flight, waiting, loaded,
// evicted, failed }, sizes in bytes (gpu 0: no cap of its own; tables: what open models keep per cube).
#include <string>

#include <lua.hpp>

#include "engine/stream/stream_cache.h"
#include "preprocess/byte_size.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"

namespace strata {

namespace {

constexpr uint64_t kLeastBudget = uint64_t(16) << 20;

uint64_t budget_at(lua_State* L, int index, const char* key) {
    std::string problem;  // raised outside the catch: a Lua error jumps past C++ frames
    try {
        uint64_t bytes = 0;
        if (lua_type(L, index) == LUA_TNUMBER) {
            const double value = lua_tonumber(L, index);
            if (!(value >= 1 && value < 9.2e18)) throw std::invalid_argument("a byte count from 16M up, not " + std::to_string(value));
            bytes = uint64_t(value);
        } else {
            bytes = parse_byte_size(luaL_checkstring(L, index));
        }
        if (bytes >= kLeastBudget) return bytes;
        problem = describe_bytes(bytes) + " is less than the least, 16M";
    } catch (const std::invalid_argument& e) {
        problem = e.what();
    }
    lua_pushfstring(L, "strata.memory: %s: %s", key, problem.c_str());
    problem = {};
    return lua_error(L);
}

int memory(lua_State* L) {
    StreamCache& cache = *StreamCache::shared();
    if (!lua_isnoneornil(L, 1)) {
        luaL_checktype(L, 1, LUA_TTABLE);
        lua::check_keys(L, 1, {"total", "gpu"});
        // Both checked before either is set: a refused call changes nothing.
        uint64_t total = 0, gpu = cache.gpu_budget();
        if (lua::get_option(L, 1, "total")) total = budget_at(L, lua_gettop(L), "total");
        lua_pop(L, 1);
        if (lua::get_option(L, 1, "gpu")) gpu = lua_isboolean(L, -1) && !lua_toboolean(L, -1) ? 0 : budget_at(L, lua_gettop(L), "gpu");
        lua_pop(L, 1);
        const StreamCache::Stats now = cache.stats();
        if (total && total < now.held_bytes)
            return luaL_error(L, "strata.memory: total: %s cannot hold the %s that the open models' tables take", describe_bytes(total).c_str(),
                              describe_bytes(now.held_bytes).c_str());
        if (gpu && gpu < now.gpu_held_bytes)
            return luaL_error(L, "strata.memory: gpu: %s cannot hold the %s that the open models' tables take on the GPU",
                              describe_bytes(gpu).c_str(), describe_bytes(now.gpu_held_bytes).c_str());
        if (total) cache.set_budget(total);
        cache.set_gpu_budget(gpu);
    }
    const StreamCache::Stats s = cache.stats();
    const std::pair<const char*, double> fields[] = {
        {"total", double(s.budget)},   {"resident", double(s.resident_bytes)}, {"reserved", double(s.reserved_bytes)},
        {"gpu", double(s.gpu_budget)}, {"gpu_resident", double(s.gpu_resident_bytes)},
        {"tables", double(s.held_bytes)}, {"gpu_tables", double(s.gpu_held_bytes)},
        {"peak", double(s.peak_bytes)}, {"cubes", double(s.resident_items)},    {"in_flight", double(s.in_flight)},
        {"waiting", double(s.waiting)}, {"loaded", double(s.loaded)},          {"evicted", double(s.evicted)},
        {"failed", double(s.failed)}};
    lua::push_numbers(L, fields);
    return 1;
}

}  // namespace

void register_memory(lua_State* L) {
    const luaL_Reg functions[] = {{"memory", memory}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata
