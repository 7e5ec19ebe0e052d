// Synthesis top of the fixed-point network: interface pragmas and the compiled-in weights.
#include "network_top.hpp"

#include "fixed_network_weights.hpp"  // generated: deltactl quantise --weights W.json --out-dir DIR

void delta_network(const DeltaNetworkConfig::input_t x[DeltaNetworkConfig::inputs],
                   DeltaNetworkConfig::output_t y[DeltaNetworkConfig::outputs]) {
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_ctrl_hs port = return )
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_none port = x)
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_vld port = y)
  DELTA_HLS_PRAGMA(HLS ARRAY_PARTITION variable = x type = complete)
  DELTA_HLS_PRAGMA(HLS ARRAY_PARTITION variable = y type = complete)
  static const delta_hls::NetworkWeights<DeltaNetworkConfig> weights = DELTA_NETWORK_WEIGHTS_INIT;
  DeltaNetworkConfig::saturation_t saturation;  // not a port: the RTL interface has none
  delta_hls::network_core<DeltaNetworkConfig>(x, weights, y, saturation);
}
