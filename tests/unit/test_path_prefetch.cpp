// A camera path's frames tell strata.render what is coming (scripting/wrap_path.cpp): each step of
// path:frames sets the poses a quarter, a half and a whole second on (the last frame at most), as the
// path samples them, and the loop's end, a break included, clears them.
#include <gtest/gtest.h>

#include <string>

#include <glm/glm.hpp>
#include <lua.hpp>

#include "scripting/runtime.h"

namespace strata {
namespace {

const char* const kPath = R"(
path = strata.path{ keys = { { position = { 0, 0, 10 }, target = { 0, 0, 0 } },
                             { position = { 10, 0, 0 }, target = { 0, 0, 0 } } }, duration = 2 }
)";

TEST(PathPrefetch, EachFrameTellsThePosesToComeAndTheLoopsEndClearsThem) {
    Runtime runtime;
    ASSERT_EQ(runtime.run_string(kPath, "path"), 0);
    // Frame 1 of 20 at 10 fps (t = 0): frames 4, 6 and 11 (0.3, 0.5 and 1.0 s) are to come.
    ASSERT_EQ(runtime.run_string("local step, state = path:frames{ fps = 10 }; step(state, 0)", "step"), 0);
    ASSERT_EQ(runtime.upcoming_poses().size(), 3u);
    const double seconds[] = {0.3, 0.5, 1.0};
    for (size_t k = 0; k < 3; ++k) {
        const glm::dvec3 p = runtime.upcoming_poses()[k].position;
        for (int axis = 0; axis < 3; ++axis) {
            lua_pushnumber(runtime.state(), p[axis]);
            lua_setglobal(runtime.state(), ("told_" + std::to_string(axis + 1)).c_str());
        }
        const std::string check = "local p = path:sample(" + std::to_string(seconds[k]) +
                                  ").position; assert(p[1] == told_1 and p[2] == told_2 and p[3] == told_3)";
        EXPECT_EQ(runtime.run_string(check, "pose"), 0) << "pose " << k;
    }
    // Near the end the poses to come stop at the last frame, counted once.
    ASSERT_EQ(runtime.run_string("local step, state = path:frames{ fps = 10 }; step(state, 18)", "late"), 0);
    EXPECT_EQ(runtime.upcoming_poses().size(), 1u);
    // A loop left by a break, or run to its end, leaves nothing to come.
    ASSERT_EQ(runtime.run_string("for i in path:frames{ fps = 10 } do if i == 3 then break end end", "break"), 0);
    EXPECT_TRUE(runtime.upcoming_poses().empty());
    ASSERT_EQ(runtime.run_string("for i in path:frames{ fps = 10 } do end", "whole"), 0);
    EXPECT_TRUE(runtime.upcoming_poses().empty());
}

}  // namespace
}  // namespace strata
