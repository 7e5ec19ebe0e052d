// Levenberg-Marquardt training of the 3-H-3 tanh network with an analytic, multithreaded Jacobian.
#include "delta/nn/training.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <thread>

#include "delta/nn/levenberg_marquardt.hpp"

namespace delta::nn {
namespace {

// Samples per block of the Jacobian. Blocks are the unit of work of the threads, and their partial
// sums are added in block order, so the result is the same for any number of threads.
constexpr Eigen::Index kBlockSamples = 1024;

// Uniform double in [0, 1) from the top 53 bits: the same on every standard library.
double uniform01(std::mt19937_64& generator) { return static_cast<double>(generator() >> 11) * 0x1.0p-53; }

struct Layers {
  Eigen::MatrixXd input_weights;   // H x 3
  Eigen::VectorXd hidden_bias;     // H
  Eigen::MatrixXd output_weights;  // 3 x H
  Eigen::Vector3d output_bias;
};

Layers unpack(const Eigen::VectorXd& x, Eigen::Index hidden) {
  Layers layers;
  Eigen::Index at = 0;
  layers.hidden_bias = x.segment(at, hidden);
  at += hidden;
  layers.input_weights = Eigen::Map<const Eigen::MatrixXd>(x.data() + at, hidden, 3);
  at += 3 * hidden;
  layers.output_bias = x.segment<3>(at);
  at += 3;
  layers.output_weights = Eigen::Map<const Eigen::MatrixXd>(x.data() + at, 3, hidden);
  return layers;
}

// The fit in degrees: prediction_k = half_range_k (v_k + 1) + output_min_k for the network output v.
class NetworkProblem : public LeastSquaresProblem {
 public:
  NetworkProblem(Eigen::MatrixXd scaled_inputs, Eigen::MatrixXd targets_deg, const Network& shape, int threads)
      : inputs_(std::move(scaled_inputs)),
        targets_(std::move(targets_deg)),
        half_range_(0.5 * (shape.output_max - shape.output_min)),
        output_min_(shape.output_min),
        hidden_(shape.hidden()),
        threads_(threads) {}

  // Predicted angles (3 x n, degrees) for scaled inputs (3 x n); the hidden outputs on request.
  // Products are coefficient-based (lazyProduct): their summation order is fixed by the code, not
  // by the cache-size-dependent blocking of Eigen's matrix product, so results do not depend on the CPU.
  Eigen::MatrixXd predict(const Layers& layers, const Eigen::MatrixXd& inputs,
                          Eigen::MatrixXd* hidden = nullptr) const {
    const Eigen::MatrixXd hidden_out =
        (layers.input_weights.lazyProduct(inputs).colwise() + layers.hidden_bias).array().tanh().matrix();
    Eigen::MatrixXd out = layers.output_weights.lazyProduct(hidden_out).colwise() + layers.output_bias;
    out = ((out.array() + 1.0).colwise() * half_range_.array()).colwise() + output_min_.array();
    if (hidden) *hidden = hidden_out;
    return out;
  }

  double sum_squared_error_on(const Eigen::VectorXd& x, const Eigen::MatrixXd& inputs,
                              const Eigen::MatrixXd& targets) const {
    return (targets - predict(unpack(x, hidden_), inputs)).squaredNorm();
  }

  double sum_squared_error(const Eigen::VectorXd& x) override { return sum_squared_error_on(x, inputs_, targets_); }

  // J^T J and J^T e from per-block sums over samples, using the structure of the Jacobian rather
  // than building it (5x fewer operations). Row (n, k) of J, with u~ = [1, u_n] and
  // g = half_range_k LW(k, :) .* tanh'(z_n):
  //   hidden parameters [b1; IW(:)] (index i + H m):  u~_m g_i       (a Kronecker product u~ (x) g)
  //   output parameters of joint k [b2_k; LW(k, :)]:  half_range_k [1; h_n]; other joints' are 0.
  // Summing over k and n gives, with W_m = tanh'(Z) .* u~_m and Hb = [1; h]:
  //   hidden-hidden block (m, m') = (LW^T S^2 LW) .* (W_m W_m'^T)
  //   hidden block m x output k   = s_k^2 diag(LW(k, :)) W_m Hb^T
  //   output k x output k         = s_k^2 Hb Hb^T
  NormalEquations normal_equations(const Eigen::VectorXd& x) override {
    const Eigen::Index samples = inputs_.cols();
    const Eigen::Index blocks = (samples + kBlockSamples - 1) / kBlockSamples;
    std::vector<BlockSums> partial(static_cast<std::size_t>(blocks));
    const Layers layers = unpack(x, hidden_);
    auto work = [&](int thread, int thread_count) {
      for (Eigen::Index block = thread; block < blocks; block += thread_count) {
        partial[static_cast<std::size_t>(block)] =
            block_sums(layers, block * kBlockSamples, std::min(samples, (block + 1) * kBlockSamples));
      }
    };
    const int thread_count = static_cast<int>(std::max<Eigen::Index>(1, std::min<Eigen::Index>(threads_, blocks)));
    std::vector<std::thread> pool;
    for (int t = 1; t < thread_count; ++t) pool.emplace_back(work, t, thread_count);
    work(0, thread_count);
    for (std::thread& thread : pool) thread.join();
    BlockSums total = partial.front();
    for (std::size_t b = 1; b < partial.size(); ++b) total.add(partial[b]);  // fixed order: deterministic

    const Eigen::Index h = hidden_;
    const Eigen::Index parameters = x.size();
    NormalEquations result{Eigen::MatrixXd::Zero(parameters, parameters), Eigen::VectorXd::Zero(parameters)};
    const Eigen::Vector3d s2 = half_range_.cwiseAbs2();
    const Eigen::MatrixXd lw_weighted =
        layers.output_weights.transpose().lazyProduct(s2.asDiagonal() * layers.output_weights);
    for (Eigen::Index m = 0; m < 4; ++m) {
      for (Eigen::Index m2 = m; m2 < 4; ++m2) {
        const Eigen::MatrixXd block = lw_weighted.cwiseProduct(total.hidden_hidden[pair_index(m, m2)]);
        result.jtj.block(h * m2, h * m, h, h) = block.transpose();  // lower triangle: row block m2 >= m
      }
      result.jte.segment(h * m, h) = total.hidden_gradient[static_cast<std::size_t>(m)];
    }
    for (Eigen::Index k = 0; k < 3; ++k) {
      // Output parameters of joint k: j = 0 -> b2_k, j = 1 + i -> LW(k, i).
      auto output_index = [h, k](Eigen::Index j) { return j == 0 ? 4 * h + k : 4 * h + 3 + k + 3 * (j - 1); };
      for (Eigen::Index j = 0; j <= h; ++j) {
        for (Eigen::Index j2 = 0; j2 <= h; ++j2) {
          result.jtj(output_index(j), output_index(j2)) = s2[k] * total.output_output(j, j2);
        }
        for (Eigen::Index m = 0; m < 4; ++m) {
          for (Eigen::Index i = 0; i < h; ++i) {
            result.jtj(output_index(j), h * m + i) =
                s2[k] * layers.output_weights(k, i) * total.hidden_output[static_cast<std::size_t>(m)](i, j);
          }
        }
        result.jte[output_index(j)] = half_range_[k] * total.output_gradient(j, k);
      }
    }
    // Output rows sit below the hidden rows; copy the lower triangle up (the output blocks were
    // written in full).
    result.jtj.triangularView<Eigen::StrictlyUpper>() = result.jtj.transpose();
    return result;
  }

 private:
  static std::size_t pair_index(Eigen::Index m, Eigen::Index m2) {  // m <= m2 < 4 -> 0..9
    return static_cast<std::size_t>(m * 4 - m * (m - 1) / 2 + (m2 - m));
  }

  struct BlockSums {
    std::array<Eigen::MatrixXd, 10> hidden_hidden;   // W_m W_m'^T, m <= m'
    std::array<Eigen::MatrixXd, 4> hidden_output;    // W_m Hb^T: H x (H + 1)
    Eigen::MatrixXd output_output;                   // Hb Hb^T: (H + 1) x (H + 1)
    std::array<Eigen::VectorXd, 4> hidden_gradient;  // sum_n u~_nm tanh'(z_n) .* (LW^T S e_n)
    Eigen::MatrixXd output_gradient;                 // Hb E^T: (H + 1) x 3
    void add(const BlockSums& other) {
      for (std::size_t p = 0; p < hidden_hidden.size(); ++p) hidden_hidden[p] += other.hidden_hidden[p];
      for (std::size_t m = 0; m < 4; ++m) {
        hidden_output[m] += other.hidden_output[m];
        hidden_gradient[m] += other.hidden_gradient[m];
      }
      output_output += other.output_output;
      output_gradient += other.output_gradient;
    }
  };

  BlockSums block_sums(const Layers& layers, Eigen::Index begin, Eigen::Index end) const {
    const Eigen::Index count = end - begin;
    const Eigen::Index h = hidden_;
    const Eigen::MatrixXd inputs = inputs_.middleCols(begin, count);
    Eigen::MatrixXd hidden_out;
    const Eigen::MatrixXd errors = targets_.middleCols(begin, count) - predict(layers, inputs, &hidden_out);  // degrees
    const Eigen::ArrayXXd slope = 1.0 - hidden_out.array().square();  // tanh', H x n
    std::array<Eigen::MatrixXd, 4> weighted;                          // W_m = tanh' .* u~_m
    weighted[0] = slope.matrix();
    for (Eigen::Index m = 1; m < 4; ++m) weighted[m] = (slope.rowwise() * inputs.row(m - 1).array()).matrix();
    Eigen::MatrixXd augmented(h + 1, count);  // Hb = [1; h]
    augmented.row(0).setOnes();
    augmented.bottomRows(h) = hidden_out;
    const Eigen::MatrixXd back =
        (slope * layers.output_weights.transpose().lazyProduct(half_range_.asDiagonal() * errors).array()).matrix();
    // Sample-major copies (n x ...): every coefficient of the products below is then a dot product
    // of two contiguous columns, which the coefficient-based product vectorises.
    std::array<Eigen::MatrixXd, 4> weighted_t;
    for (std::size_t m = 0; m < 4; ++m) weighted_t[m] = weighted[m].transpose();
    const Eigen::MatrixXd augmented_t = augmented.transpose();
    const Eigen::MatrixXd back_t = back.transpose();
    const Eigen::MatrixXd inputs_t = inputs.transpose();
    const Eigen::MatrixXd errors_t = errors.transpose();
    BlockSums sums;
    for (Eigen::Index m = 0; m < 4; ++m) {
      for (Eigen::Index m2 = m; m2 < 4; ++m2) {
        sums.hidden_hidden[pair_index(m, m2)] = weighted_t[m].transpose().lazyProduct(weighted_t[m2]);
      }
      sums.hidden_output[m] = weighted_t[m].transpose().lazyProduct(augmented_t);
      sums.hidden_gradient[m] = m == 0 ? Eigen::VectorXd(back_t.colwise().sum().transpose())
                                       : Eigen::VectorXd(back_t.transpose().lazyProduct(inputs_t.col(m - 1)));
    }
    sums.output_output = augmented_t.transpose().lazyProduct(augmented_t);
    sums.output_gradient = augmented_t.transpose().lazyProduct(errors_t);
    return sums;
  }

  Eigen::MatrixXd inputs_;   // 3 x N, mapminmax-scaled positions
  Eigen::MatrixXd targets_;  // 3 x N, degrees
  Eigen::Vector3d half_range_;
  Eigen::Vector3d output_min_;
  Eigen::Index hidden_;
  int threads_;
};

Eigen::MatrixXd columns_of(const std::vector<Vec3>& values, const std::vector<std::size_t>& indices) {
  Eigen::MatrixXd matrix(3, static_cast<Eigen::Index>(indices.size()));
  for (std::size_t i = 0; i < indices.size(); ++i) matrix.col(static_cast<Eigen::Index>(i)) = values[indices[i]];
  return matrix;
}

}  // namespace

Eigen::VectorXd network_parameters(const Network& network) {
  const Eigen::Index h = network.hidden();
  Eigen::VectorXd x(7 * h + 3);
  x.segment(0, h) = network.hidden_bias;
  x.segment(h, 3 * h) = Eigen::Map<const Eigen::VectorXd>(network.input_weights.data(), 3 * h);
  x.segment<3>(4 * h) = network.output_bias;
  x.segment(4 * h + 3, 3 * h) = Eigen::Map<const Eigen::VectorXd>(network.output_weights.data(), 3 * h);
  return x;
}

void set_network_parameters(Network& network, const Eigen::VectorXd& parameters) {
  const Layers layers = unpack(parameters, network.hidden());
  network.input_weights = layers.input_weights;
  network.hidden_bias = layers.hidden_bias;
  network.output_weights = layers.output_weights;
  network.output_bias = layers.output_bias;
}

LeastSquaresProblem::NormalEquations network_normal_equations(const Network& network, const std::vector<Vec3>& inputs_m,
                                                              const std::vector<Vec3>& targets_deg, int threads) {
  std::vector<std::size_t> all(inputs_m.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  std::vector<Vec3> scaled(inputs_m.size());
  for (std::size_t i = 0; i < inputs_m.size(); ++i) scaled[i] = network.scale_input(inputs_m[i]);
  NetworkProblem problem(columns_of(scaled, all), columns_of(targets_deg, all), network, threads);
  return problem.normal_equations(network_parameters(network));
}

Network initial_network(const std::vector<Vec3>& inputs_m, const std::vector<Vec3>& targets_deg, int hidden,
                        std::uint64_t seed) {
  if (hidden < 1) throw std::invalid_argument("the hidden layer needs at least one neuron");
  Network network;
  network.input_min = network.input_max = inputs_m.front();
  network.output_min = network.output_max = targets_deg.front();
  for (std::size_t i = 0; i < inputs_m.size(); ++i) {
    network.input_min = network.input_min.cwiseMin(inputs_m[i]);
    network.input_max = network.input_max.cwiseMax(inputs_m[i]);
    network.output_min = network.output_min.cwiseMin(targets_deg[i]);
    network.output_max = network.output_max.cwiseMax(targets_deg[i]);
  }
  for (int k = 0; k < 3; ++k) {
    if (!(network.input_max[k] > network.input_min[k])) {
      throw std::invalid_argument("the positions do not vary along axis " + std::string(1, "xyz"[k]) +
                                  ": mapminmax needs a range");
    }
    // A constant output gets a unit range so that scaling stays defined.
    if (!(network.output_max[k] > network.output_min[k])) {
      network.output_min[k] -= 0.5;
      network.output_max[k] += 0.5;
    }
  }
  // Nguyen-Widrow (MATLAB initnw) for the tansig layer on inputs scaled to [-1, 1]: random
  // directions of magnitude 0.7 H^(1/3), biases spread evenly over the active region.
  std::mt19937_64 generator(seed);
  const double magnitude = 0.7 * std::pow(static_cast<double>(hidden), 1.0 / 3.0);
  network.input_weights.resize(hidden, 3);
  network.hidden_bias.resize(hidden);
  for (int i = 0; i < hidden; ++i) {
    Eigen::Vector3d direction;
    do {
      for (int m = 0; m < 3; ++m) direction[m] = 2.0 * uniform01(generator) - 1.0;
    } while (direction.norm() < 1e-3);
    network.input_weights.row(i) = magnitude * direction.normalized().transpose();
    const double spread = hidden == 1 ? 0.0 : -1.0 + 2.0 * i / (hidden - 1.0);
    network.hidden_bias[i] = magnitude * spread * (network.input_weights(i, 0) >= 0.0 ? 1.0 : -1.0);
  }
  // The linear layer as MATLAB's rands: uniform in [-1, 1].
  network.output_weights.resize(3, hidden);
  for (int i = 0; i < hidden; ++i) {
    for (int k = 0; k < 3; ++k) network.output_weights(k, i) = 2.0 * uniform01(generator) - 1.0;
  }
  for (int k = 0; k < 3; ++k) network.output_bias[k] = 2.0 * uniform01(generator) - 1.0;
  return network;
}

TrainingResult train_network(const std::vector<Vec3>& inputs_m, const std::vector<Vec3>& targets_deg,
                             const TrainingOptions& options,
                             const std::function<void(const TrainingEpoch&)>& progress) {
  if (inputs_m.size() != targets_deg.size()) throw std::invalid_argument("inputs and targets differ in count");
  if (inputs_m.size() < kMinTrainingSamples) {
    throw std::invalid_argument("training needs at least " + std::to_string(kMinTrainingSamples) + " samples");
  }
  TrainingResult result;
  result.network = initial_network(inputs_m, targets_deg, options.hidden, options.seed);

  // Seeded split (Fisher-Yates on a generator separate from the weights'), kept in time order.
  std::vector<std::size_t> order(inputs_m.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::mt19937_64 split_generator(options.seed ^ 0x9e3779b97f4a7c15ULL);
  for (std::size_t i = order.size() - 1; i > 0; --i) std::swap(order[i], order[split_generator() % (i + 1)]);
  const auto validation_count = static_cast<std::size_t>(std::floor(options.validation_fraction * order.size()));
  std::vector<std::size_t> validation(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(validation_count));
  std::vector<std::size_t> training(order.begin() + static_cast<std::ptrdiff_t>(validation_count), order.end());
  std::sort(validation.begin(), validation.end());
  std::sort(training.begin(), training.end());
  result.training_samples = training.size();
  result.validation_samples = validation.size();

  std::vector<Vec3> scaled(inputs_m.size());
  for (std::size_t i = 0; i < inputs_m.size(); ++i) scaled[i] = result.network.scale_input(inputs_m[i]);
  const int threads =
      options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  NetworkProblem problem(columns_of(scaled, training), columns_of(targets_deg, training), result.network, threads);
  const Eigen::MatrixXd validation_inputs = columns_of(scaled, validation);
  const Eigen::MatrixXd validation_targets = columns_of(targets_deg, validation);
  auto validation_mse = [&](const Eigen::VectorXd& x) {
    if (validation.empty()) return 0.0;
    return problem.sum_squared_error_on(x, validation_inputs, validation_targets) / (3.0 * validation.size());
  };

  const Eigen::VectorXd x0 = network_parameters(result.network);
  Eigen::VectorXd best = x0;
  double best_validation = validation.empty() ? 0.0 : validation_mse(x0);
  double best_training = problem.sum_squared_error(x0) / (3.0 * training.size());
  int failures = 0;
  LmOptions lm;
  lm.max_epochs = options.max_epochs;
  lm.plateau_epochs = options.plateau_epochs;
  lm.plateau_fraction = options.plateau_fraction;
  const LmResult run = levenberg_marquardt(problem, x0, lm, [&](const LmEpoch& epoch, const Eigen::VectorXd& x) {
    TrainingEpoch report{epoch.epoch, epoch.sse / (3.0 * training.size()), validation_mse(x), epoch.mu,
                         epoch.gradient_norm};
    if (progress) progress(report);
    // Without a validation set every accepted step is the best so far.
    if (validation.empty() || report.validation_mse_deg2 < best_validation) {
      best_validation = report.validation_mse_deg2;
      best_training = report.training_mse_deg2;
      best = x;
      result.best_epoch = epoch.epoch;
      failures = 0;
    } else if (++failures >= options.max_validation_failures) {
      return std::string("validation");
    }
    return std::string();
  });
  set_network_parameters(result.network, best);
  result.epochs = run.epochs;
  result.stop_reason = run.stop_reason;
  result.training_mse_deg2 = best_training;
  result.validation_mse_deg2 = best_validation;
  return result;
}

}  // namespace delta::nn
