// The ring seam of an embedding (HYBRID.md §2): along the border of the zone, where the terrain's grid
// meets the skirt, the triangles that join the grid's edge at whatever level each stretch of the border
// is drawn at to the skirt's finest samples. Here the border, found once per embedding, and the seam's
// triangles for given levels, as vertex identities (this is the CPU twin of the compute pass that emits
// them per frame; positions come from the grid's and the skirt's own decodes).
//
// In raster index space: samples (column, row), the border's loops counter-clockwise around the zone
// (the zone on their left).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "preprocess/footprint.h"

namespace strata {

struct BorderStep {
    int64_t column = 0, row = 0;  // the sample the step starts at; it ends at the loop's next sample
    // The finest cell outside the zone beside the step (its cube's level decides the grid edge), or −1
    // for a step along the raster's own border, where no grid lies beyond the skirt.
    int64_t outside_column = -1, outside_row = -1;
    bool seamed() const { return outside_column >= 0; }
};

// The border of the zone (the PC and CC cells of `zone`) in finest steps: one loop per boundary
// component (a zone may enclose cells it does not cover), each counter-clockwise, from its lowest
// sample. Deterministic.
std::vector<std::vector<BorderStep>> zone_border(const CellCovers& zone, int64_t columns, int64_t rows);

// A vertex of the seam: the grid's sample at (column, row) as its cube draws it at `level`, or the skirt's
// sample at loop position `step` (the sample that step starts at).
struct SeamVertex {
    bool grid = false;
    int64_t column = 0, row = 0;
    uint32_t level = 0;  // grid
    uint32_t step = 0;   // skirt
    bool operator==(const SeamVertex&) const = default;
};

// The seam's triangles along one loop, for the levels its steps' outside cells are drawn at (one per
// step; ignored for unseamed steps), `finest` the terrain's L, the raster `columns` × `rows`. Per step, independently of the others
// (as the compute pass runs it): the fan triangle from the start of the grid edge holding it at its level
// to the step's skirt edge, and for the last step of a grid edge, the triangle on the grid edge itself.
// Counter-clockwise in raster space, like the skirt's.
std::vector<std::array<SeamVertex, 3>> ring_seam(std::span<const BorderStep> loop, std::span<const uint32_t> levels, uint32_t finest,
                                                 int64_t columns, int64_t rows);
// One step's share of that (step `i` of `loop`, its outside cell drawn at `level`), appended to `out`:
// nothing for an unseamed step.
void ring_seam_step(std::span<const BorderStep> loop, size_t i, uint32_t level, uint32_t finest, int64_t columns, int64_t rows,
                    std::vector<std::array<SeamVertex, 3>>& out);

}  // namespace strata
