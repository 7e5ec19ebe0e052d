// Inverse-kinematics back ends behind `deltactl ik`: the math model, the float network, the
// fixed-point golden model, the HLS C++ and the Verilated RTL register themselves by name.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "delta/geometry.hpp"

namespace delta {

struct IkRow {
  Vec3 alpha_deg = Vec3::Zero();
  std::array<std::int64_t, 3> raw{};  // integer output codes (fixed-point back ends only)
  std::string error;                  // empty when the pose was evaluated
};

class IkBackend {
 public:
  virtual ~IkBackend() = default;
  virtual bool has_raw_codes() const { return false; }
  // One row per position, in order. Faults are reported per row, never as NaN. With in_time_order
  // the positions are one recording's rows in time order, and the model's time-ordered parts (the
  // deployed model's backlash compensation, started afresh at the first row) apply; without it
  // every pose stands alone. Models without such parts ignore the flag.
  virtual std::vector<IkRow> evaluate(const std::vector<Vec3>& positions_m, bool in_time_order) = 0;
  // Whether the model has parts that depend on the order of the rows.
  virtual bool has_time_ordered_parts() const { return false; }
  // Counters worth reporting after a run (saturations, out-of-range inputs), as "name: value".
  virtual std::vector<std::string> report() const { return {}; }
};

// weights_path is empty for back ends that need no weights (the math model).
using IkBackendFactory = std::function<std::unique_ptr<IkBackend>(const std::string& weights_path)>;

struct RegisterIkBackend {
  RegisterIkBackend(const std::string& name, const std::string& summary, IkBackendFactory factory);
};

struct IkBackendEntry {
  std::string name;
  std::string summary;
  IkBackendFactory factory;
};
const std::vector<IkBackendEntry>& ik_backends();

// Throws std::invalid_argument naming the known back ends for an unknown name.
std::unique_ptr<IkBackend> make_ik_backend(const std::string& name, const std::string& weights_path);

}  // namespace delta
