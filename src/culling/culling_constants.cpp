// Compile-time checks of the culling constants (the CPU reference lives beside this file).
#include "culling/culling_constants.h"

static_assert(MDS_CULL_ETA > 0.0 && MDS_CULL_ETA < 1.0, "Eq. 20 needs 0 < eta < 1");
static_assert(MDS_CULL_HISTOGRAM_BINS <= 64, "paper 000 Sect. 7.4: at most 64 bins");
