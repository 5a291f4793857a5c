// Compile-time checks of the culling constants (the CPU reference lives beside this file).
#include "culling/culling_constants.h"

static_assert(MDS_CULL_ETA > 0.0 && MDS_CULL_ETA < 1.0, "Eq. 20 needs 0 < eta < 1");
static_assert(MDS_CULL_HISTOGRAM_BINS <= 64, "paper 000 Sect. 7.4: at most 64 bins");
static_assert(MDS_CULL_C_MEDIUM_DEFAULT < MDS_CULL_C_OCC_DEFAULT, "Sect. 5.1: L < M < O");
static_assert(MDS_CULL_N_BUDGET_DEFAULT >= 1, "Eq. 21 needs N_budget >= 1");
static_assert(MDS_CULL_NORMAL_TABLE_SIZE >= 2, "supplement A: interpolation needs 2 entries");
static_assert(MDS_CULL_DEPTH_EMPTY < 3.4028234e38, "the empty depth must be finite in float");
