// Where deltactl finds what it ships (the weights, the paper-like robot, the dashboard's page).
#pragma once

#include <string>

namespace delta {

// <prefix>/share/deltactl beside the program's <prefix>/bin: /usr/share/deltactl once installed
// (the package), <build>/share/deltactl in a build, whose entries link to the source tree
// (CMakeLists.txt). /usr/share/deltactl if the program's own is not there. No path is compiled in,
// so a checkout in another folder compiles deltactl to the same objects (compiler-cache hits).
std::string shipped_data_dir();

}  // namespace delta
