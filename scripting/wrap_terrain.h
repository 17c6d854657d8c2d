// What other bindings share of the terrain's (wrap_terrain.cpp): the placement options of an embedding.
#pragma once

#include <lua.hpp>

#include "preprocess/embedding_file.h"

namespace strata {

// Options at = {lon, lat}, scale and heading, or matrix = {16 numbers} (the site's model coordinates →
// the terrain's, column-major), of the table at `index` (absent: none), over `placement`; any of the
// first three clears its matrix. A Lua error naming the option that is wrong.
SitePlacement check_placement(lua_State* L, int index, SitePlacement placement);

}  // namespace strata
