// The editor as seen from Lua: strata.view() and the editor object's methods (wrap_editor.cpp).
#pragma once

#include <memory>

#include "editor/editor.h"

struct lua_State;

namespace strata {

// Adds strata.view to the runtime's `strata` module (the editor lives in the executable, not in the
// scripting library, so the commands that can show a window register it).
void register_editor(lua_State* L);

// Opens the editor on `state` (a new camera when it has none), replacing any previous one, and keeps it
// drawing beside the script or the REPL (Runtime::pump_live_windows). The Lua state owns it.
std::shared_ptr<Editor> open_editor(Runtime& runtime, SceneState state);
// Pushes the open editor's Lua object (nil when none was opened).
void push_editor(lua_State* L);

}  // namespace strata
