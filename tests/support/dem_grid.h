// A real terrain for the tests and benchmarks: a regular latitude/longitude elevation grid (a DEM) read
// from a netCDF classic file into a triangle mesh, such as data/trinidad.nc that scripts/setup.sh
// fetches (3 arc-second samples of southern Colorado, 1201 × 2401, elevations in feet).
#pragma once

#include "preprocess/mesh.h"

#include <cstddef>
#include <filesystem>
#include <string>

namespace strata::test {

// The samples to take. Rows are the grid's first dimension (latitude), columns its second (longitude),
// both counted in file order. The window covers rows first_row … first_row + rows − 1 (0 rows: to the
// grid's last) and likewise columns, and takes every stride-th sample of it from its first.
struct DemWindow {
    size_t first_column = 0, first_row = 0;
    size_t columns = 0, rows = 0;
    size_t stride = 1;
};

// The unit of the stored elevations. from_units_attribute: the variable's `units` attribute says
// (feet, ft, foot: converted to metres; m, metre(s), meter(s): as they are; another: an error); a
// variable without one is taken as it is. trinidad.nc has none, though its values are feet.
enum class ElevationUnit { from_units_attribute, metres, feet };

struct DemOptions {
    std::string variable;  // the elevation variable, or empty: the file's first 2-D float variable
    ElevationUnit unit = ElevationUnit::from_units_attribute;
};

// Reads the window of a netCDF classic (CDF-1) file's 2-D float variable over (latitude, longitude),
// whose coordinate variables (1-D, float or double, named as the dimensions) give each sample's place.
// Returns a regular grid mesh in metres in a local frame: x east, y north, z up (the elevation), the
// origin at the window's south-west corner (x, y = 0 there; z is the elevation itself); x is the
// longitude difference × cos(the window's central latitude) × 111 320 m, y the latitude difference
// × 110 574 m. Two triangles per grid square (diagonal from the sample of lower row and column),
// counter-clockwise seen from +z. A sample equal to the fill value (_FillValue, else netCDF's default
// fill, or missing_value) or NaN has no vertex; the triangles touching it are left out.
// Throws InputError naming the file and the problem for anything else: another format (netCDF-4,
// 64-bit offset), a malformed or truncated header or data, no such variable, packed values
// (scale_factor, add_offset), coordinates missing or not monotonic, a window outside the grid.
Mesh read_dem_grid(const std::filesystem::path& path, const DemWindow& window = {}, const DemOptions& options = {});

}  // namespace strata::test
