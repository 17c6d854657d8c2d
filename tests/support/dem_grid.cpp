// The netCDF classic format as its specification ("The NetCDF Classic Format Specification", Unidata)
// writes it, big-endian throughout:
//   header   = 'C' 'D' 'F' 0x01, numrecs, dim_list, gatt_list, var_list
//   dim_list = ABSENT | 0x0A count dim*        dim  = name length (0: the record dimension)
//   att_list = ABSENT | 0x0C count attr*       attr = name nc_type count values (padded to 4 bytes)
//   var_list = ABSENT | 0x0B count var*        var  = name count dimid* att_list nc_type vsize begin
//   name     = length bytes (padded to 4)      ABSENT = 0 0
// A non-record variable's values lie contiguous from `begin`, in C order.
#include "tests/support/dem_grid.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>
#include <vector>

namespace strata::test {
namespace {

enum NcType : uint32_t { nc_byte = 1, nc_char, nc_short, nc_int, nc_float, nc_double };

size_t type_size(uint32_t type) {
    switch (type) {
        case nc_byte: case nc_char: return 1;
        case nc_short: return 2;
        case nc_int: case nc_float: return 4;
        case nc_double: return 8;
        default: return 0;
    }
}

template <class T>
T from_big_endian(const uint8_t* bytes) {
    using Bits = std::conditional_t<sizeof(T) == 8, uint64_t, uint32_t>;
    Bits bits = 0;
    for (size_t i = 0; i < sizeof(T); ++i) bits = bits << 8 | bytes[i];
    return std::bit_cast<T>(bits);
}

struct Attribute {
    std::string name;
    uint32_t type = 0;
    uint32_t count = 0;
    std::vector<uint8_t> values;  // as stored (big-endian)

    std::string text() const { return type == nc_char ? std::string(values.begin(), values.end()) : std::string(); }
    // The first value as a number (an attribute of another numeric type than its variable's is legal).
    std::optional<double> number() const {
        if (count == 0) return std::nullopt;
        switch (type) {
            case nc_byte: return double(int8_t(values[0]));
            case nc_short: return double(int16_t(values[0] << 8 | values[1]));
            case nc_int: return double(from_big_endian<int32_t>(values.data()));
            case nc_float: return double(from_big_endian<float>(values.data()));
            case nc_double: return from_big_endian<double>(values.data());
            default: return std::nullopt;
        }
    }
};

struct Dimension {
    std::string name;
    uint32_t length = 0;  // 0: the record dimension
};

struct Variable {
    std::string name;
    std::vector<uint32_t> dims;
    std::vector<Attribute> attributes;
    uint32_t type = 0;
    uint64_t begin = 0;

    const Attribute* attribute(const std::string& wanted) const {
        for (const Attribute& a : attributes)
            if (a.name == wanted) return &a;
        return nullptr;
    }
};

struct Header {
    std::vector<Dimension> dims;
    std::vector<Variable> vars;

    const Variable* variable(const std::string& name) const {
        for (const Variable& v : vars)
            if (v.name == name) return &v;
        return nullptr;
    }
};

class NetcdfFile {
public:
    explicit NetcdfFile(const std::filesystem::path& path) : path_(path), in_(path, std::ios::binary) {
        if (!in_) fail("cannot be opened");
        std::error_code error;
        size_ = std::filesystem::file_size(path, error);
        if (error) fail("cannot be sized: " + error.message());
    }

    [[noreturn]] void fail(const std::string& problem) const { throw InputError(path_.string() + ": " + problem); }
    uint64_t size() const { return size_; }

    Header read_header() {
        check_magic();
        u32();  // numrecs: only record variables need it, and those are refused
        Header header;
        for (size_t i = 0, n = list_count(0x0A, "dimension", 8); i < n; ++i) {
            Dimension d;
            d.name = name();
            d.length = u32();
            header.dims.push_back(std::move(d));
        }
        attributes();  // the global attributes say nothing the grid needs
        for (size_t i = 0, n = list_count(0x0B, "variable", 24); i < n; ++i) header.vars.push_back(variable(header));
        return header;
    }

    // count big-endian values of `type` from byte `offset`, converted to double.
    std::vector<double> read_numbers(uint64_t offset, size_t count, uint32_t type, const std::string& what) {
        const size_t size = type_size(type);
        if (offset > size_ || count * size > size_ - offset)
            fail(what + " ends at byte " + std::to_string(offset + count * size) + ", past the end of the file (" +
                 std::to_string(size_) + " bytes): truncated?");
        std::vector<uint8_t> bytes(count * size);
        in_.clear();
        in_.seekg(std::streamoff(offset));
        if (!in_.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()))) fail(what + " cannot be read");
        std::vector<double> numbers(count);
        for (size_t i = 0; i < count; ++i)
            numbers[i] = type == nc_float ? from_big_endian<float>(&bytes[i * size]) : from_big_endian<double>(&bytes[i * size]);
        return numbers;
    }

private:
    void check_magic() {
        std::array<uint8_t, 4> magic{};
        bytes(magic.data(), 4);
        if (magic == std::array<uint8_t, 4>{'C', 'D', 'F', 1}) return;
        const std::string convert = "; convert it with `nccopy -k classic`";
        if (magic == std::array<uint8_t, 4>{'C', 'D', 'F', 2}) fail("a netCDF 64-bit offset (CDF-2) file, not netCDF classic (CDF-1)" + convert);
        if (magic == std::array<uint8_t, 4>{'C', 'D', 'F', 5}) fail("a netCDF 64-bit data (CDF-5) file, not netCDF classic (CDF-1)" + convert);
        if (magic == std::array<uint8_t, 4>{0x89, 'H', 'D', 'F'}) fail("a netCDF-4 (HDF5) file, not netCDF classic (CDF-1)" + convert);
        fail("not a netCDF classic file (it does not start with \"CDF\\x01\")");
    }

    void bytes(void* out, size_t count) {
        if (!in_.read(static_cast<char*>(out), std::streamsize(count)))
            fail("the header ends early, at byte " + std::to_string(size_) + " (truncated?)");
        position_ += count;
    }
    uint32_t u32() {
        uint8_t b[4];
        bytes(b, 4);
        return from_big_endian<uint32_t>(b);
    }
    void skip_padding(size_t count) {
        uint8_t pad[3];
        bytes(pad, (4 - count % 4) % 4);
    }
    // A count the rest of the file can hold `bytes_each` bytes per element of: bounds every allocation.
    size_t count_within_file(uint64_t count, uint64_t bytes_each, const std::string& what) {
        if (count > (size_ - std::min(size_, position_)) / bytes_each)
            fail(what + " count " + std::to_string(count) + " at byte " + std::to_string(position_ - 4) +
                 " is more than the file holds");
        return size_t(count);
    }
    std::string name() {
        const size_t length = count_within_file(u32(), 1, "name length");
        std::string text(length, '\0');
        bytes(text.data(), length);
        skip_padding(length);
        return text;
    }
    // A list's tag and element count: ABSENT (0 0) is an empty list.
    size_t list_count(uint32_t tag, const std::string& what, uint64_t bytes_each) {
        const uint32_t found = u32(), count = u32();
        if (found == 0 && count == 0) return 0;
        if (found != tag)
            fail("the " + what + " list at byte " + std::to_string(position_ - 8) + " has tag " + std::to_string(found) +
                 " where " + std::to_string(tag) + " or an empty list was expected");
        return count_within_file(count, bytes_each, what);
    }
    std::vector<Attribute> attributes() {
        std::vector<Attribute> list;
        for (size_t i = 0, n = list_count(0x0C, "attribute", 12); i < n; ++i) {
            Attribute a;
            a.name = name();
            a.type = u32();
            if (type_size(a.type) == 0) fail("attribute '" + a.name + "' has unknown type " + std::to_string(a.type));
            a.count = uint32_t(count_within_file(u32(), type_size(a.type), "attribute '" + a.name + "' value"));
            a.values.resize(a.count * type_size(a.type));
            bytes(a.values.data(), a.values.size());
            skip_padding(a.values.size());
            list.push_back(std::move(a));
        }
        return list;
    }
    Variable variable(const Header& header) {
        Variable v;
        v.name = name();
        for (size_t i = 0, n = count_within_file(u32(), 4, "dimension"); i < n; ++i) {
            const uint32_t dim = u32();
            if (dim >= header.dims.size())
                fail("variable '" + v.name + "' uses dimension " + std::to_string(dim) + " of " + std::to_string(header.dims.size()));
            v.dims.push_back(dim);
        }
        v.attributes = attributes();
        v.type = u32();
        if (type_size(v.type) == 0) fail("variable '" + v.name + "' has unknown type " + std::to_string(v.type));
        u32();  // vsize: redundant (the dimensions give the size) and clipped for large variables
        v.begin = u32();
        return v;
    }

    std::filesystem::path path_;
    std::ifstream in_;
    uint64_t size_ = 0;
    uint64_t position_ = 0;
};

// What the grid's file says about its elevation variable.
struct Elevations {
    const Variable* variable = nullptr;
    size_t rows = 0, columns = 0;
    std::vector<double> latitudes, longitudes;  // per row, per column
    double metres_per_unit = 1;
    float fill = 9.9692099683868690e+36f;  // netCDF's default fill for floats (NC_FILL_FLOAT)
    std::optional<float> missing;
};

std::string lowercase(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return s;
}

double metres_per_unit(NetcdfFile& file, const Variable& v, ElevationUnit unit) {
    if (unit == ElevationUnit::feet) return 0.3048;
    if (unit == ElevationUnit::metres) return 1;
    const Attribute* units = v.attribute("units");
    if (!units) return 1;
    const std::string text = lowercase(units->text());
    if (text == "feet" || text == "ft" || text == "foot") return 0.3048;
    if (text == "m" || text == "metre" || text == "metres" || text == "meter" || text == "meters") return 1;
    file.fail("variable '" + v.name + "' has units '" + units->text() + "', neither feet nor metres");
}

bool is_coordinate(const Variable& v, const char* units, const char* short_name, const char* long_name) {
    const Attribute* a = v.attribute("units");
    const std::string name = lowercase(v.name);
    return (a && lowercase(a->text()) == units) || name == short_name || name == long_name;
}

// The coordinate variable of the elevation variable's dimension `axis`: 1-D over it, named as it.
std::vector<double> coordinates(NetcdfFile& file, const Header& header, const Variable& elevation, int axis) {
    const Dimension& dim = header.dims[elevation.dims[axis]];
    const Variable* v = header.variable(dim.name);
    if (!v || v->dims.size() != 1 || v->dims[0] != elevation.dims[axis] || (v->type != nc_float && v->type != nc_double))
        file.fail("dimension '" + dim.name + "' of variable '" + elevation.name + "' has no float or double coordinate variable");
    const bool latitude = axis == 0;
    if (!(latitude ? is_coordinate(*v, "degrees_north", "lat", "latitude") : is_coordinate(*v, "degrees_east", "lon", "longitude")))
        file.fail("variable '" + elevation.name + "' is over (" + header.dims[elevation.dims[0]].name + ", " +
                  header.dims[elevation.dims[1]].name + "); only (latitude, longitude) grids are read");
    std::vector<double> values = file.read_numbers(v->begin, dim.length, v->type, "coordinate variable '" + v->name + "'");
    const bool increasing = values.back() > values.front();
    for (size_t i = 1; i < values.size(); ++i)
        if (!std::isfinite(values[i]) || !(increasing ? values[i] > values[i - 1] : values[i] < values[i - 1]))
            file.fail("coordinate variable '" + v->name + "' is not strictly monotonic at index " + std::to_string(i));
    return values;
}

const Variable& elevation_variable(NetcdfFile& file, const Header& header, const std::string& wanted) {
    auto is_grid = [&](const Variable& v) { return v.dims.size() == 2 && v.type == nc_float; };
    if (!wanted.empty()) {
        const Variable* v = header.variable(wanted);
        if (!v) file.fail("no variable '" + wanted + "'");
        if (!is_grid(*v)) file.fail("variable '" + wanted + "' is not a 2-D float variable");
        return *v;
    }
    for (const Variable& v : header.vars)
        if (is_grid(v)) return v;
    file.fail("no 2-D float variable");
}

Elevations describe(NetcdfFile& file, const Header& header, const DemOptions& options) {
    Elevations e;
    e.variable = &elevation_variable(file, header, options.variable);
    const Variable& v = *e.variable;
    e.rows = header.dims[v.dims[0]].length, e.columns = header.dims[v.dims[1]].length;
    if (e.rows == 0 || e.columns == 0) file.fail("variable '" + v.name + "' is a record variable, which is not read");
    if (v.attribute("scale_factor") || v.attribute("add_offset"))
        file.fail("variable '" + v.name + "' is packed (scale_factor, add_offset), which is not read");
    if (v.begin > file.size() || e.rows > (file.size() - v.begin) / 4 / e.columns)
        file.fail("variable '" + v.name + "' (" + std::to_string(e.rows) + " × " + std::to_string(e.columns) +
                  " floats from byte " + std::to_string(v.begin) + ") runs past the end of the file (" +
                  std::to_string(file.size()) + " bytes): truncated?");
    e.latitudes = coordinates(file, header, v, 0);
    e.longitudes = coordinates(file, header, v, 1);
    e.metres_per_unit = metres_per_unit(file, v, options.unit);
    if (const Attribute* fill = v.attribute("_FillValue"); fill && fill->number()) e.fill = float(*fill->number());
    if (const Attribute* missing = v.attribute("missing_value"); missing && missing->number()) e.missing = float(*missing->number());
    return e;
}

// The window's sample indices along one axis of `total` samples.
std::vector<size_t> window_samples(NetcdfFile& file, size_t first, size_t count, size_t stride, size_t total, const char* axis) {
    if (stride == 0) file.fail("window stride 0");
    if (first >= total || (count != 0 && count > total - first))
        file.fail(std::string("window ") + axis + " from " + std::to_string(first) + (count ? " to " + std::to_string(first + count - 1) : "") +
                  " lie outside the grid's " + std::to_string(total) + " " + axis);
    if (count == 0) count = total - first;
    std::vector<size_t> samples;
    for (size_t i = first; i < first + count; i += stride) samples.push_back(i);
    if (samples.size() < 2)
        file.fail(std::string("the window takes fewer than 2 ") + axis + " (" + std::to_string(count) + " with stride " +
                  std::to_string(stride) + ")");
    return samples;
}

}  // namespace

Mesh read_dem_grid(const std::filesystem::path& path, const DemWindow& window, const DemOptions& options) {
    NetcdfFile file(path);
    const Header header = file.read_header();
    const Elevations e = describe(file, header, options);
    const std::vector<size_t> rows = window_samples(file, window.first_row, window.rows, window.stride, e.rows, "rows");
    const std::vector<size_t> columns = window_samples(file, window.first_column, window.columns, window.stride, e.columns, "columns");
    const size_t width = columns.size(), height = rows.size();
    if (width * height > std::numeric_limits<uint32_t>::max()) file.fail("the window holds more than 2^32 samples");

    // The local frame: x east and y north from the window's south-west corner.
    const double lon_first = e.longitudes[columns.front()], lon_last = e.longitudes[columns.back()];
    const double lat_first = e.latitudes[rows.front()], lat_last = e.latitudes[rows.back()];
    const double west = std::min(lon_first, lon_last), south = std::min(lat_first, lat_last);
    const double metres_per_degree_east = std::cos(0.5 * (lat_first + lat_last) * std::numbers::pi / 180) * 111320.0;
    const double metres_per_degree_north = 110574.0;

    // Every sample's position, and whether it holds an elevation; a row at a time from the file.
    std::vector<float> grid(3 * width * height);
    std::vector<bool> valid(width * height);
    for (size_t i = 0; i < height; ++i) {
        const uint64_t offset = e.variable->begin + (uint64_t(rows[i]) * e.columns + columns.front()) * 4;
        const std::vector<double> row = file.read_numbers(offset, columns.back() - columns.front() + 1, nc_float,
                                                          "variable '" + e.variable->name + "'");
        const float y = float((e.latitudes[rows[i]] - south) * metres_per_degree_north);
        for (size_t j = 0; j < width; ++j) {
            const float value = float(row[columns[j] - columns.front()]);
            valid[i * width + j] = !std::isnan(value) && value != e.fill && value != e.missing;
            float* p = &grid[3 * (i * width + j)];
            p[0] = float((e.longitudes[columns[j]] - west) * metres_per_degree_east);
            p[1] = y;
            p[2] = float(value * e.metres_per_unit);
        }
    }

    // Two triangles per square, (a b c) and (a c d) from its corner a of lower row and column, going
    // round through the next column first: counter-clockwise from +z when rows go north and columns
    // east, or both the other way; otherwise the winding turns.
    const bool mirrored = (lat_last > lat_first) != (lon_last > lon_first);
    std::vector<uint32_t> corners;
    corners.reserve(6 * (width - 1) * (height - 1));
    for (size_t i = 0; i + 1 < height; ++i)
        for (size_t j = 0; j + 1 < width; ++j) {
            const uint32_t a = uint32_t(i * width + j), b = a + 1, c = uint32_t(b + width), d = uint32_t(a + width);
            for (const std::array<uint32_t, 3>& t : {std::array{a, b, c}, std::array{a, c, d}}) {
                if (!valid[t[0]] || !valid[t[1]] || !valid[t[2]]) continue;
                corners.insert(corners.end(), {t[0], mirrored ? t[2] : t[1], mirrored ? t[1] : t[2]});
            }
        }

    // Only the samples some triangle uses become vertices, in grid order.
    std::vector<uint32_t> vertex_of(width * height, UINT32_MAX);
    for (uint32_t s : corners) vertex_of[s] = 0;
    Mesh mesh;
    for (size_t s = 0; s < width * height; ++s)
        if (vertex_of[s] == 0) {
            vertex_of[s] = uint32_t(mesh.vertex_count());
            mesh.positions.insert(mesh.positions.end(), &grid[3 * s], &grid[3 * s + 3]);
        }
    mesh.indices.reserve(corners.size());
    for (uint32_t s : corners) mesh.indices.push_back(vertex_of[s]);
    if (mesh.indices.empty()) file.fail("the window holds no triangle: every square touches a fill value");
    return mesh;
}

}  // namespace strata::test
