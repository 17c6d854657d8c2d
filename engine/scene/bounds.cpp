#include "engine/scene/bounds.h"

namespace strata {

Box transformed(const Box& box, const glm::dmat4& matrix) {
    if (!box.valid()) return box;
    // Arvo's method: each output axis is the translation plus, per input axis, the smaller and the
    // larger of the matrix entry times the box's two extents.
    Box out{glm::dvec3(matrix[3]), glm::dvec3(matrix[3])};
    for (int column = 0; column < 3; ++column)
        for (int row = 0; row < 3; ++row) {
            const double a = matrix[column][row] * box.lo[column], b = matrix[column][row] * box.hi[column];
            out.lo[row] += a < b ? a : b;
            out.hi[row] += a < b ? b : a;
        }
    return out;
}

}  // namespace strata
