// Debian's libsystemc.so references sc_main (its own main() calls it). Programs that only use the
// sc_fixed data types (deltactl, the C-simulation tests) never start a SystemC kernel, so they get
// this weak stand-in; a program with a real sc_main overrides it.
#include <cstdio>

extern "C" __attribute__((weak)) int sc_main(int, char**) {
  std::fprintf(stderr, "sc_main: this program uses only SystemC data types, not the kernel\n");
  return 1;
}
