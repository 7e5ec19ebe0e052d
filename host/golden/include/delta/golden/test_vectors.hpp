// Raw input vectors for the golden-vs-HLS comparison: saturation corners, the workspace grid,
// random positions inside and beyond the trained range, and random raw codes of the whole input
// format. Deterministic for a seed; the first `count` vectors of one seed are always the same.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "delta/golden/fixed_network.hpp"

namespace delta::golden {

using RawInput = std::array<std::int64_t, 3>;

// Per input: the extremes of the raw format, the centre, and codes one LSB either side of where u
// starts to saturate (u = 1 - 2^-16 rounds up to 1, i.e. offset = (2^15 - 1/2) 2^shift).
inline std::vector<RawInput> saturation_corners(const QuantisedNetwork& q) {
  std::array<std::vector<std::int64_t>, 3> values;
  const std::int64_t max_code = (std::int64_t{1} << (q.formats.input_bits - 1)) - 1;
  for (int j = 0; j < 3; ++j) {
    const std::int64_t edge = ((std::int64_t{1} << (q.formats.scaled_input_bits - 1)) << q.input_shift[j]) -
                              (std::int64_t{1} << (q.input_shift[j] - 1));
    const std::int64_t c = q.input_centre[j];
    values[j] = {-max_code - 1, max_code, c, c + edge - 1, c + edge, c - edge - 1, c - edge, c - edge + 1};
  }
  std::vector<RawInput> corners;
  for (std::int64_t a : values[0])
    for (std::int64_t b : values[1])
      for (std::int64_t c : values[2]) corners.push_back({a, b, c});
  return corners;
}

// `count` vectors: the corners, then (in equal parts) a grid of the trained range plus 30 % margin,
// uniform positions inside the trained range, uniform positions up to 3 half-ranges beyond it, and
// uniform raw codes of the whole 32-bit input format.
inline std::vector<RawInput> csim_vectors(const QuantisedNetwork& q, const Vec3& trained_min_m,
                                          const Vec3& trained_max_m, std::size_t count, std::uint64_t seed) {
  std::vector<RawInput> vectors = saturation_corners(q);
  if (vectors.size() > count) vectors.resize(count);
  const std::size_t remaining = count - vectors.size();
  const std::size_t part = remaining / 4;
  const Vec3 centre = (trained_min_m + trained_max_m) / 2.0;
  const Vec3 half = (trained_max_m - trained_min_m) / 2.0;
  const int per_axis = std::max(2, static_cast<int>(std::ceil(std::cbrt(static_cast<double>(part)))));
  for (int a = 0; a < per_axis && vectors.size() < count; ++a)
    for (int b = 0; b < per_axis && vectors.size() < count; ++b)
      for (int c = 0; c < per_axis && vectors.size() < count; ++c) {
        const Vec3 t(a, b, c);
        const Vec3 p = centre + 1.3 * half.cwiseProduct(2.0 * t / (per_axis - 1) - Vec3::Ones());
        vectors.push_back(encode_position(q.formats, p));
      }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<std::int64_t> raw(-(std::int64_t{1} << (q.formats.input_bits - 1)),
                                                  (std::int64_t{1} << (q.formats.input_bits - 1)) - 1);
  std::size_t kind = 0;
  while (vectors.size() < count) {
    Vec3 p;
    switch (kind++ % 3) {
      case 0:
        for (int j = 0; j < 3; ++j) p[j] = centre[j] + unit(rng) * half[j];
        vectors.push_back(encode_position(q.formats, p));
        break;
      case 1:
        for (int j = 0; j < 3; ++j) p[j] = centre[j] + 3.0 * unit(rng) * half[j];
        vectors.push_back(encode_position(q.formats, p));
        break;
      default:
        vectors.push_back({raw(rng), raw(rng), raw(rng)});
    }
  }
  return vectors;
}

// A seeded walk of network answers for the backlash compensation tests: half-plays (random up to
// 4000 LSBs, or the widest the format holds in every fifth walk), then answers that move by up to
// three half-plays per step and sometimes jump to the output format's edges.
struct CompensationWalk {
  QuantisedCompensation compensation;
  std::vector<std::array<std::int64_t, 3>> answers;
};

inline std::vector<CompensationWalk> compensation_walks(const Formats& formats, int walks, int steps,
                                                        std::uint64_t seed) {
  std::mt19937_64 generator(seed);
  const std::int64_t top = (std::int64_t{1} << (formats.output_bits - 1)) - 1;
  const std::int64_t bottom = -(std::int64_t{1} << (formats.output_bits - 1));
  std::vector<CompensationWalk> result(static_cast<std::size_t>(walks));
  for (int walk = 0; walk < walks; ++walk) {
    CompensationWalk& w = result[static_cast<std::size_t>(walk)];
    for (auto& h : w.compensation.half_play) {
      h = walk % 5 == 0 ? (std::int64_t{1} << formats.half_play_bits) - 1
                        : static_cast<std::int64_t>(generator() % 4000);
    }
    std::array<std::int64_t, 3> s{};
    for (auto& v : s) v = static_cast<std::int64_t>(generator() % 2000000) - 1000000;
    for (int i = 0; i < steps; ++i) {
      for (int j = 0; j < 3; ++j) {
        const std::uint64_t kind = generator() % 100;
        if (kind == 0) {
          s[j] = top;
        } else if (kind == 1) {
          s[j] = bottom;
        } else {
          const std::int64_t span = 3 * w.compensation.half_play[j] + 2;
          s[j] = std::clamp<std::int64_t>(s[j] + static_cast<std::int64_t>(generator() % (2 * span + 1)) - span, bottom,
                                          top);
        }
      }
      w.answers.push_back(s);
    }
  }
  return result;
}

}  // namespace delta::golden
