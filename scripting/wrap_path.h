// Camera paths as Lua values (userdata holding a std::shared_ptr<CameraPath>), for the other wrap_*.cpp
// files: a saved scene holds paths.
#pragma once

namespace strata {

inline constexpr const char* kPathType = "strata.Path";

}  // namespace strata
