// Identifiability of a fitted model: weak directions, the measurement that separates them, and
// parameter confidence intervals (internal to the diagnosis library).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "delta/diagnosis/diagnose.hpp"

namespace delta::diagnosis {

// The extra measurement that would separate the parameters of a weak direction ((index, weight)).
std::string advice_for(const std::vector<std::pair<int, double>>& components);

// 1.96 standard errors per parameter of `fit` (zero for absent families): residual variance on
// the `rows` it was fitted on times the inverse of its J^T J (weak prior and gauge included).
// Rows are taken as independent, so for slowly moving quantised angles the intervals are optimistic.
Parameters confidence_half_widths(const FitResult& fit, std::size_t rows);

}  // namespace delta::diagnosis
