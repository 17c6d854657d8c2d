// What the readers of GDAL rasters share (elevation rasters, orthophotos): GDAL's drivers registered
// once, its messages kept quiet and put into ours, and a dataset opened read-only with a message that
// names the file.
#pragma once

#include <gdal_priv.h>

#include <filesystem>
#include <memory>
#include <string>

namespace strata {

void register_gdal_drivers();

// GDAL reports errors through a handler (printing by default) and the thread's last error: while one
// of these lives, nothing is printed, and what GDAL said last is ours to put in a message.
class QuietGdal {
public:
    QuietGdal();
    ~QuietGdal();
    QuietGdal(const QuietGdal&) = delete;
    QuietGdal& operator=(const QuietGdal&) = delete;
    // " (GDAL: what it said)", or nothing.
    static std::string last();
};

struct DatasetCloser {
    void operator()(GDALDataset* dataset) const { GDALClose(GDALDataset::ToHandle(dataset)); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetCloser>;

// Opens `file` as a raster, read-only. Throws InputError naming the file: missing, not a regular file,
// not a raster GDAL reads.
DatasetPtr open_dataset(const std::filesystem::path& file);

}  // namespace strata
