// deltactl config check: reads and validates the lab PC's configuration file.
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/deploy/config.hpp"

namespace delta {
namespace {

const RegisterCommand kRegister("config", 90, [](CLI::App& root) {
  auto* config = root.add_subcommand("config", "Check the lab PC's configuration file (/etc/deltactl/deltactl.conf)");
  config->require_subcommand(1, 1);
  auto* check = config->add_subcommand(
      "check",
      "Read and validate the configuration file and load its weights as the service does; print it resolved, or "
      "FILE:LINE: reason and exit 2");
  auto path = std::make_shared<std::string>(deploy::kDefaultConfigPath);
  check->add_option("--config", *path, "configuration file")->capture_default_str();
  check->callback([path] {
    const deploy::DeployConfig config = deploy::read_config(*path);
    deploy::check_service_can_run(config);
    std::cout << "# " << config.path << ": valid\n" << deploy::describe(config);
  });
});

}  // namespace
}  // namespace delta
