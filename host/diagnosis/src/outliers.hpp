// Outlier rows of a recording: isolated spikes in the measured position (stage glitches) or in
// the encoder angles (internal to the diagnosis library).
#pragma once

#include <string>
#include <vector>

#include "delta/diagnosis/diagnose.hpp"

namespace delta::diagnosis {

// Rows whose position or angles jump away from both neighbours and back: the spike s_i = x_i -
// (x_{i-1} + x_{i+1}) / 2 is large against the recording's own spread (20 robust standard
// deviations, at least 2 um or 3 encoder steps) and the neighbours' spikes point the other way
// with about half its size (a turn of the trajectory or of backlash is a kink, not a spike).
// Only rows sampled at the usual interval from both neighbours are judged.
std::vector<Outlier> find_outliers(const std::vector<Sample>& rows, const std::string& recording,
                                   double encoder_step_deg);

// The median interval between neighbouring rows (the recording's sample period), seconds.
double usual_interval_s(const std::vector<Sample>& rows);

// Whether rows i-1 and i are one usual interval apart (within 25 %); false for i = 0 and across a
// gap in time or a row left out.
bool regular_step(const std::vector<Sample>& rows, std::size_t i, double usual_s);

// The rows not listed (row numbers are 1-based).
std::vector<Sample> without_outliers(const std::vector<Sample>& rows, const std::vector<Outlier>& outliers);

}  // namespace delta::diagnosis
