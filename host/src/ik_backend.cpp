// The registry of inverse-kinematics back ends.
#include "delta/ik_backend.hpp"

#include <stdexcept>

namespace delta {
namespace {
std::vector<IkBackendEntry>& registry() {
  static std::vector<IkBackendEntry> entries;
  return entries;
}
}  // namespace

RegisterIkBackend::RegisterIkBackend(const std::string& name, const std::string& summary, IkBackendFactory factory) {
  registry().push_back({name, summary, std::move(factory)});
}

const std::vector<IkBackendEntry>& ik_backends() { return registry(); }

std::unique_ptr<IkBackend> make_ik_backend(const std::string& name, const std::string& weights_path) {
  std::string known;
  for (const IkBackendEntry& entry : registry()) {
    if (entry.name == name) return entry.factory(weights_path);
    known += (known.empty() ? "" : ", ") + entry.name;
  }
  throw std::invalid_argument("unknown back end '" + name + "' (this build has: " + known + ")");
}

}  // namespace delta
