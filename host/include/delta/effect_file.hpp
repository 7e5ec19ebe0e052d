// Effect files (docs/contracts.md): a JSON object naming effects of the vocabulary with parameters.
//
// Per-joint effects take an array of three numbers. transmission_error takes either
// {"amplitude_deg": [..3], "period_deg": [..3], "phase_rad": [..3]} or three [A, P, phi] triples.
// frame_misalignment takes {"rx","ry","rz" (deg), "tx","ty","tz" (m)} or [rx, ry, rz, tx, ty, tz].
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "delta/effects.hpp"

namespace delta {

// Throws InputError naming the file, the line and the reason: bad JSON, a name outside the
// vocabulary, wrong shapes, non-finite numbers, or a transmission period of zero.
EffectSet read_effect_file(const std::string& path);

// Parses an already-read text; `path` names it in errors.
EffectSet parse_effects(const std::string& text, const std::string& path);

// The canonical JSON form (object form for the structured effects).
nlohmann::json effects_to_json(const EffectSet& effects);

}  // namespace delta
