// A level's border listings (border_table.h) on disk, keyed by the block of the cube listing them, so
// that memory holds only the tables of the blocks being simplified, whatever the scan's size.
#pragma once

#include <span>

#include "preprocess/border_table.h"
#include "preprocess/run_spill.h"

namespace strata::build {

// Appends entries to the runs of their blocks (entries of one block, in order, from any thread).
void append_listings(std::span<const BorderEntry> entries, RunSpill& listed);

// The table a level-`level` block looks its points up in: the listings of it and of its 26
// neighbours that lie within its reach. No other block can list a point the block uses: a vertex
// lies within σ0·s_l (σ0 < 1/2) of its cube, so two cubes sharing a point touch, and so do their
// blocks. Every listing of such a point is there, so the table answers as the level's whole table.
BorderTable block_border_table(const RunSpill& listed, CubeKey block, const Frame& f, uint32_t level);

// Every listing of the level (level 0's, for the root).
BorderTable whole_border_table(const RunSpill& listed);

}  // namespace strata::build
