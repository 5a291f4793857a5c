// Constants of the probabilistic occlusion culling (paper 000, Ibrahim et al. 2021).
// Shared by the CPU reference (double) and, later, the GLSL shaders.
#pragma once

#define MDS_CULL_ETA 0.98                // Eq. 20: clamp n_max to eta * D(d_min, d_s)
#define MDS_CULL_C_OCC_DEFAULT 0.95      // Sect. 5.1: confidence threshold for class O
#define MDS_CULL_HISTOGRAM_BINS 64       // Sect. 7.4: at most 64 density bins per pixel
