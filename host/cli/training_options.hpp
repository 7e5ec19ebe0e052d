// The training options that `deltactl train` and `deltactl table1` share.
#pragma once

#include <CLI/CLI.hpp>

#include "delta/nn/training.hpp"
#include "options.hpp"

namespace delta::nn {

inline void add_training_options(CLI::App* sub, TrainingOptions& training) {
  sub->add_option("--seed", training.seed, "seed of the initial weights and the validation split")
      ->capture_default_str()
      ->check(options::seed());
  sub->add_option("--hidden", training.hidden, "hidden tanh neurons")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  sub->add_option("--max-epochs", training.max_epochs, "epoch limit")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
}

}  // namespace delta::nn
