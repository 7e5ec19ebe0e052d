// `ik --backend fixed`: the golden fixed-point model (plain integer C++), raw output codes.
#include "delta/golden/fixed_point_backend.hpp"

namespace delta::golden {
namespace {

const RegisterIkBackend fixed_backend("fixed", "the golden fixed-point model (integer C++), raw output codes",
                                      [](const std::string& weights_path) {
                                        nn::WeightsFile weights = nn::read_weights_file(weights_path);
                                        QuantisedNetwork q = quantise_file(weights_path, weights);
                                        RawEvaluator evaluator = [q](const std::array<std::int64_t, 3>& codes) {
                                          return evaluate_raw(q, codes);
                                        };
                                        CompensationStep compensation = golden_compensation(q.compensation);
                                        return std::make_unique<FixedPointIkBackend>("fixed", std::move(weights),
                                                                                     std::move(q), std::move(evaluator),
                                                                                     std::move(compensation));
                                      });

}  // namespace
}  // namespace delta::golden
