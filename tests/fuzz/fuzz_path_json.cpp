// Fuzz target: camera path JSON (engine/path/path_json.cpp) as `strata` loads a path file. Properties:
// bad text is a std::runtime_error starting with the source name; an accepted path samples without
// failing and saves as JSON that loads back to the same keys.
#include <stdexcept>
#include <string_view>

#include "engine/path/camera_path.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

constexpr std::string_view kSource = "fuzz.json";

void exercise(const strata::CameraPath& path) {
    const double duration = path.duration();
    for (double t : {-1.0, 0.0, duration / 3, duration / 2, duration, duration + 1}) path.sample(t);
    for (size_t key = 0; key < path.key_count(); ++key) path.key_time(key);
    path.length();
    path.frame_count(30);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using strata::fuzz::violated;
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    try {
        const strata::CameraPath path = strata::CameraPath::from_json(text, kSource);
        exercise(path);
        const std::string saved = path.to_json();
        strata::CameraPath again = [&] {
            try {
                return strata::CameraPath::from_json(saved, "saved");
            } catch (const std::runtime_error& error) {
                violated(std::string("a loaded path saves as JSON that does not load: ") + error.what());
            }
        }();
        if (again.to_json() != saved) violated("a saved path loads back different");
    } catch (const std::runtime_error& error) {
        strata::fuzz::expect_named(error.what(), kSource);
    }
    return 0;
}
