// Which families the model keeps: forward selection on held-out error, a restart of a misled
// ripple, backward elimination and a two-for-one swap search (internal to the diagnosis library).
#pragma once

#include <utility>
#include <vector>

#include "candidate.hpp"

namespace delta::diagnosis {

struct Selection {
  FamilySet families;
  std::vector<Family> order;                              // kept families in the order they were added
  Parameters theta;                                       // fitted on the (thinned) FIT rows
  Candidate model;                                        // the kept model and its held-out prediction
  std::vector<Candidate> forward_path;                    // the model after each kept family
  std::vector<std::pair<Family, Candidate>> last_round;   // the round that stopped
  std::vector<std::pair<Family, Candidate>> first_round;  // every family alone (from the nominal model)
  bool path_changed = false;                              // the ripple restart changed the forward path's end
  std::vector<SelectionStep> steps;
  std::vector<Elimination> eliminated;
};

// `nominal` is the nominal model scored on CHECK (no fit).
// Sets data.long_ripples when a ripple longer than a joint's travel on FIT was taken in.
Selection select_families(PipelineData& data, const Candidate& nominal);

}  // namespace delta::diagnosis
