// Fuzz target: OpenSceneGraph .path files (engine/path/osg_path.cpp) as import_osg_path reads them:
// the control points, then a CameraPath through them. Properties: bad text is a std::runtime_error
// starting with the source name; an accepted path samples without failing.
#include <sstream>
#include <stdexcept>
#include <string>

#include "engine/path/osg_path.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string source = "fuzz.path";
    std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
    std::vector<strata::Keyframe> keys;
    try {
        keys = strata::read_osg_path(in, source);
    } catch (const std::runtime_error& error) {
        strata::fuzz::expect_named(error.what(), source);
        return 0;
    }
    try {
        // import_osg_path prefixes the file name to what from_keys finds wrong (times too close, ...).
        const strata::CameraPath path = strata::CameraPath::from_keys(std::move(keys));
        const double duration = path.duration();
        for (double t : {0.0, duration / 3, duration / 2, duration}) path.sample(t);
        std::ostringstream out;
        strata::write_osg_path(path, out);
    } catch (const std::runtime_error&) {
    }
    return 0;
}
