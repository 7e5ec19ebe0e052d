// `ik --backend hls`: the HLS C++ of the network (hls/network, sc_fixed C simulation), raw output codes.
#include "delta/golden/fixed_point_backend.hpp"
#include "network_csim.hpp"

namespace delta::golden {
namespace {

const RegisterIkBackend hls_backend(
    "hls", "the HLS C++ (sc_fixed C-simulation), raw output codes", [](const std::string& weights_path) {
      using Config = delta_hls::DefaultNetworkConfig;
      nn::WeightsFile weights = nn::read_weights_file(weights_path);
      QuantisedNetwork q = quantise_file(weights_path, weights);
      if (q.hidden != Config::hidden) {
        throw InputError(weights_path, 0,
                         "has " + std::to_string(q.hidden) +
                             " hidden neurons; the HLS build is "
                             "configured for " +
                             std::to_string(Config::hidden));
      }
      std::shared_ptr<delta_hls::NetworkWeights<Config>> hls_weights = delta_hls::load_weights<Config>(q);
      RawEvaluator evaluator = [hls_weights](const std::array<std::int64_t, 3>& codes) {
        unsigned flags = 0;
        RawOutput out;
        out.alpha = delta_hls::evaluate_codes<Config>(*hls_weights, codes, &flags);
        out.scaled_input_saturated = flags & delta_hls::kScaledInputSaturated;
        out.tanh_input_saturated = flags & delta_hls::kTanhInputSaturated;
        out.output_saturated = flags & delta_hls::kOutputSaturated;
        return out;
      };
      auto compensation = std::make_shared<delta_hls::CompensationCodes<Config>>(q.compensation);
      CompensationStep step = [compensation](const std::array<std::int64_t, 3>& codes, bool first) {
        if (first) compensation->restart();
        return compensation->step(codes);
      };
      return std::make_unique<FixedPointIkBackend>("hls", std::move(weights), std::move(q), std::move(evaluator),
                                                   std::move(step));
    });

}  // namespace
}  // namespace delta::golden
