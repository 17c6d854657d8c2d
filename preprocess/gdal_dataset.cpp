#include "preprocess/gdal_dataset.h"

#include <cpl_error.h>

#include <mutex>

#include "preprocess/mesh.h"

namespace strata {

void register_gdal_drivers() {
    static std::once_flag once;
    std::call_once(once, [] { GDALAllRegister(); });
}

QuietGdal::QuietGdal() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
}

QuietGdal::~QuietGdal() { CPLPopErrorHandler(); }

std::string QuietGdal::last() {
    const char* message = CPLGetLastErrorMsg();
    return message && *message ? std::string(" (GDAL: ") + message + ")" : std::string();
}

DatasetPtr open_dataset(const std::filesystem::path& file) {
    register_gdal_drivers();
    QuietGdal quiet;
    std::error_code error;
    if (!std::filesystem::is_regular_file(file, error))
        throw InputError(file.string() + ": " + (std::filesystem::exists(file, error) ? "not a regular file" : "no such file"));
    DatasetPtr dataset(GDALDataset::Open(file.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
    if (!dataset) throw InputError(file.string() + ": not a raster GDAL reads" + QuietGdal::last());
    return dataset;
}

}  // namespace strata
