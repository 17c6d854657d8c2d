// A level's border listings (border_table.h) on disk, keyed by the block of the cube listing them, so
// that memory holds only the tables of the blocks being simplified, whatever the scan's size.
#pragma once

#include <vector>

#include "preprocess/border_table.h"
#include "preprocess/run_spill.h"

namespace strata::build {

// Appends entries to the runs of their blocks, each block's in their order (sorting `entries` by
// block, stably); from any thread, as long as no two threads append entries of one block.
void append_listings(std::vector<BorderEntry>& entries, RunSpill& listed);

// The table a level-`level` block looks its points up in: the listings of it and of its 26
// neighbours that lie within its reach. No other block can list a point the block uses: a vertex
// lies within σ0·s_l (σ0 < 1/2) of its cube, so two cubes sharing a point touch, and so do their
// blocks. Every listing of such a point is there, so the table answers as the level's whole table.
BorderTable block_border_table(const RunSpill& listed, CubeKey block, const Frame& f, uint32_t level);

// Every listing of the level (level 0's, for the root).
BorderTable whole_border_table(const RunSpill& listed);

}  // namespace strata::build
