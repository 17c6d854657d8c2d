// What other bindings share of the terrain's (wrap_terrain.cpp): the placement options of an embedding.
#pragma once

#include <lua.hpp>

#include "preprocess/embedding_file.h"

namespace strata {

// Options at = {lon, lat}, scale and heading, or matrix = {16 numbers} (the site's model coordinates →
// the terrain's, column-major), of the table at `index` (absent: none), over `placement`: what a table
// changes of `placement` places the site (at, scale and heading clearing its matrix), so that a table
// t:placement gave, one part edited, moves it; a table changing both is refused. A Lua error naming the
// option that is wrong.
SitePlacement check_placement(lua_State* L, int index, SitePlacement placement);

}  // namespace strata
