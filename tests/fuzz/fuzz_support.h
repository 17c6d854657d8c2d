// Shared by the fuzz targets (tests/fuzz/README.md): a scratch file for readers that only take a path,
// and the checks a target makes on every input beyond "did not crash".
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace strata::fuzz {

// A failed property: printed, then abort(), which libFuzzer records as a crash with its input and the
// replay test reports as a failure.
[[noreturn]] inline void violated(const std::string& what) {
    std::fprintf(stderr, "fuzz property violated: %s\n", what.c_str());
    std::abort();
}

// House rule: an error names the file (or source) it is about, first.
inline void expect_named(std::string_view message, std::string_view name) {
    if (message.substr(0, name.size()) != name)
        violated("error does not start with \"" + std::string(name) + "\": " + std::string(message));
}

// One directory per process, in /dev/shm where it exists (no disk I/O per run), removed at exit.
class ScratchDir {
public:
    static const std::filesystem::path& path() {
        static ScratchDir dir;
        return dir.path_;
    }

private:
    ScratchDir() {
        std::error_code ec;
        const std::filesystem::path base =
            std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
        path_ = base / ("strata-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(path_, ec);
        if (ec) violated("cannot create " + path_.string() + ": " + ec.message());
    }
    ~ScratchDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    std::filesystem::path path_;
};

// Writes `size` bytes to `name` in the scratch directory and returns its path.
inline std::filesystem::path scratch_file(const std::string& name, const void* data, size_t size) {
    const std::filesystem::path path = ScratchDir::path() / name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(static_cast<const char*>(data), std::streamsize(size));
    out.close();
    if (!out) violated("cannot write " + path.string());
    return path;
}

}  // namespace strata::fuzz
