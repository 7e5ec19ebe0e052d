// The synthesis top of the fixed-point network (Vitis HLS): one call evaluates one position.
#pragma once

#include "network.hpp"

typedef delta_hls::DefaultNetworkConfig DeltaNetworkConfig;

// x: plate position in metres, Q4.28 (ports x_0..x_2); y: joint angles in degrees, Q10.14 (ports
// y_0..y_2 with ap_vld); block-level ap_ctrl_hs. The weights are compiled in from the header that
// `deltactl quantise` generates (fixed_network_weights.hpp).
void delta_network(const DeltaNetworkConfig::input_t x[DeltaNetworkConfig::inputs],
                   DeltaNetworkConfig::output_t y[DeltaNetworkConfig::outputs]);
