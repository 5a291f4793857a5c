// Morton sort of a float32 xyz array (the mapped raw input, record_view.h) that moves the
// positions themselves (paper 000, §6: particles ordered along the Z-order curve before nodes
// and meshlets are built). Instead of sorting (key, index) pairs and gathering the positions
// later through the permutation (a random access into the input per particle), it
//   1. histograms the top key digit (computing the keys, split across the threads),
//   2. scatters the position of every particle into its digit's bucket (stable: each thread
//      writes its contiguous segment at its own offsets; keys computed again, cheaper than
//      storing them),
//   3. sorts the buckets independently on the threads (the bucket's keys computed into
//      per-thread scratch, radix_sort.h's sort of (key, index) pairs, then the bucket's
//      positions permuted the same way).
// The result is identical to a stable sort by key: keys ascending, ties in input order. No key
// array is kept: whoever needs the keys of the sorted positions computes them again
// (morton_keys_of_xyz, morton.h's XyzMortonKeys). 8 bytes per particle less of fresh memory, which on the
// 2-core VM costs more to map than the keys cost to compute (docs/results/convert.md).
// Keys come from MortonGrid::key of the float's double value (BMI2 pdep where the CPU has it,
// else the magic-bits spreading; the same keys either way).
#pragma once

#include <cstddef>
#include <cstdint>

#include "convert/big_buffer.h"
#include "convert/morton.h"

namespace mds::convert {

// xyz_sorted must have 3n elements (allocated by the caller, e.g. prefaulted during pass A). On
// return it holds the positions of xyz in stable key order.
void sort_xyz_by_key(const float* xyz, size_t n, const MortonGrid& grid, unsigned threads, float* xyz_sorted);

// keys[i] = grid.key of position i, for n positions (keys has n elements).
void morton_keys_of_xyz(const float* xyz, size_t n, const MortonGrid& grid, uint64_t* keys);

}  // namespace mds::convert
