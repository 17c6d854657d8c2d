// What other bindings share of the terrain's (wrap_terrain.cpp): the placement options of an embedding.
#pragma once

#include <lua.hpp>

#include "preprocess/embedding_file.h"

namespace strata {

// Options at = {lon, lat}, scale and heading of the table at `index` (absent: none), over `placement`;
// a Lua error naming the option that is wrong.
SitePlacement check_placement(lua_State* L, int index, SitePlacement placement);

}  // namespace strata
