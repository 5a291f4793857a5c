// Morton sort of a float32 xyz array (the mapped raw input, record_view.h) that moves the
// positions along with the keys (paper 000, §6: particles ordered along the Z-order curve before
// nodes and meshlets are built). Instead of sorting (key, index) pairs and gathering the
// positions later through the permutation (a random access into the input per particle), it
//   1. histograms the top key digit (computing the keys, split across the threads),
//   2. scatters key and position of every particle into its digit's bucket (stable: each thread
//      writes its contiguous segment at its own offsets; keys computed again, cheaper than
//      storing them),
//   3. sorts the buckets independently on the threads (radix_sort.h's sort of (key, index)
//      pairs inside the bucket, then the bucket's positions permuted the same way).
// The result is identical to a stable sort by key: keys ascending, ties in input order.
// Keys come from MortonGrid::key of the float's double value (BMI2 pdep where the CPU has it,
// else the magic-bits spreading; the same keys either way).
#pragma once

#include <cstddef>
#include <cstdint>

#include "convert/big_buffer.h"
#include "convert/morton.h"

namespace mds::convert {

// keys and xyz_sorted must have n and 3n elements (allocated by the caller, e.g. prefaulted
// during pass A). On return keys is sorted and xyz_sorted holds the positions in that order.
void sort_xyz_by_key(const float* xyz, size_t n, const MortonGrid& grid, unsigned threads, uint64_t* keys,
                     float* xyz_sorted);

}  // namespace mds::convert
