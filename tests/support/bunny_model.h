// The bundled real scan (data/bunny.off, fetched by scripts/setup.sh) built once per test process into
// a .hlod with four levels (0 … 3: the most its longest edges allow with σ0 ≤ 0.45).
#pragma once

#include <filesystem>
#include <memory>

#include "preprocess/hlod_builder.h"
#include "preprocess/mesh_io.h"
#include "tests/support/test_meshes.h"

namespace strata::test {

// The .hlod's path, or empty when the scan is missing (tests then skip).
inline std::filesystem::path bunny_hlod() {
    static const std::unique_ptr<TempDir> dir = std::make_unique<TempDir>();
    static const std::filesystem::path path = [] {
        const auto scan = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "bunny.off";
        if (!std::filesystem::exists(scan)) return std::filesystem::path();
        BuildSettings settings;
        settings.levels = 3;
        build_hlod(read_mesh(scan), *dir / "bunny.hlod", settings, "bunny.off");
        return *dir / "bunny.hlod";
    }();
    return path;
}

}  // namespace strata::test
