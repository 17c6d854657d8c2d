// The fuzz targets outside libFuzzer: runs every file of the given directories (or the given files)
// through LLVMFuzzerTestOneInput once, in name order. The project build links each target with this,
// as the ctest tests fuzz.replay.<target> over its corpus and regression inputs. A target's property
// failure aborts (the test fails, naming the input last started); a directory that does not exist is
// skipped (a target may have no regressions yet), but no input at all is an error.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

std::vector<std::filesystem::path> inputs_in(const std::filesystem::path& path) {
    if (!std::filesystem::is_directory(path)) return {path};
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(path))
        if (entry.is_regular_file() && entry.path().filename().string()[0] != '.') files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    return files;
}

void run(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in.eof() && in.fail()) {
        std::fprintf(stderr, "replay: cannot read %s\n", file.c_str());
        std::exit(1);
    }
    std::fprintf(stderr, "replay: %s\n", file.c_str());  // names the input if it aborts
    bytes.reserve(1);  // a non-null pointer even for an empty input, as libFuzzer passes
    LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
}

}  // namespace

int main(int argc, char** argv) {
    size_t count = 0;
    for (int a = 1; a < argc; ++a) {
        const std::filesystem::path path = argv[a];
        if (!std::filesystem::exists(path)) {
            std::printf("replay: %s does not exist, skipped\n", path.c_str());
            continue;
        }
        for (const auto& file : inputs_in(path)) run(file), ++count;
    }
    std::printf("replay: %zu inputs, no failure\n", count);
    if (count == 0) {
        std::fprintf(stderr, "replay: no inputs found\n");
        return 1;
    }
    return 0;
}
