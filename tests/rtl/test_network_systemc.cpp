// SystemC testbench: the network RTL Verilated with --sc, driven through its ap_ctrl_hs ports by
// a clocked SystemC thread, every raw output code compared with the golden model (1e4 vectors).
// A CTest entry of its own (sc_main): exit code 0 when every code matches and the latency holds.
#include <array>
#include <cstdint>
#include <filesystem>
#include <iostream>

#include <systemc.h>
#include <verilated.h>

#include "Vdelta_network_sc.h"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/test_vectors.hpp"
#include "rtl_fixture.hpp"

namespace {

constexpr int kOutputWidth = 24;      // alpha: Q10.14
constexpr int kExpectedLatency = 92;  // cycles at ReuseFactor 75 (delta_network.sv)

std::int64_t sign_extend(std::uint32_t value, int width) {
  const std::uint64_t sign = std::uint64_t{1} << (width - 1);
  return static_cast<std::int64_t>(((value & ((sign << 1) - 1)) ^ sign) - sign);
}

SC_MODULE(NetworkDriver) {
  sc_in<bool> clk;
  sc_out<bool> ap_rst, ap_start;
  sc_in<bool> ap_done, ap_idle, ap_ready;
  sc_out<std::uint32_t> u_0, u_1, u_2;  // scaled inputs (golden::scale_input), 16 bits
  sc_in<std::uint32_t> y_0, y_1, y_2;
  sc_in<bool> y_0_ap_vld, y_1_ap_vld, y_2_ap_vld;

  const delta::golden::QuantisedNetwork* network = nullptr;
  const std::vector<delta::golden::RawInput>* vectors = nullptr;
  long mismatches = 0;
  long compared = 0;
  int latency = 0;

  SC_CTOR(NetworkDriver) { SC_CTHREAD(run, clk.pos()); }

  // Signals written here reach the model after this edge; the model's outputs read here are the
  // values of the cycle that this edge ends (SystemC's evaluate/update semantics).
  void run() {
    ap_rst.write(true);
    ap_start.write(false);
    for (int i = 0; i < 4; ++i) wait();
    ap_rst.write(false);
    wait();
    for (const delta::golden::RawInput& x : *vectors) {
      const auto u = delta::golden::scale_input(*network, x).code;
      u_0.write(static_cast<std::uint32_t>(u[0]) & 0xFFFFu);
      u_1.write(static_cast<std::uint32_t>(u[1]) & 0xFFFFu);
      u_2.write(static_cast<std::uint32_t>(u[2]) & 0xFFFFu);
      ap_start.write(true);
      do wait();
      while (!ap_ready.read());  // this edge took ap_start
      ap_start.write(false);
      int cycles = 0;
      do {
        wait();
        ++cycles;
      } while (!ap_done.read());
      latency = cycles;
      const std::array<std::int64_t, 3> rtl = {sign_extend(y_0.read(), kOutputWidth),
                                               sign_extend(y_1.read(), kOutputWidth),
                                               sign_extend(y_2.read(), kOutputWidth)};
      const delta::golden::RawOutput expected = delta::golden::evaluate_raw(*network, x);
      ++compared;
      if (rtl != expected.alpha || cycles != kExpectedLatency || !y_0_ap_vld.read()) {
        if (++mismatches <= 5) {
          std::cerr << "mismatch at vector " << compared - 1 << ": rtl (" << rtl[0] << ", " << rtl[1] << ", " << rtl[2]
                    << ") golden (" << expected.alpha[0] << ", " << expected.alpha[1] << ", " << expected.alpha[2]
                    << "), latency " << cycles << "\n";
        }
      }
    }
    sc_stop();
  }
};

}  // namespace

int sc_main(int argc, char* argv[]) {
  constexpr std::uint32_t kNetworkSeed = 21;
  constexpr std::uint64_t kVectorSeed = 20260104;
  std::cout << "SystemC testbench: network seed " << kNetworkSeed << ", vector seed " << kVectorSeed << "\n";
  const delta::golden::QuantisedNetwork q = delta::golden::quantise(delta::test::random_network(kNetworkSeed));
  const std::string mem_dir = delta::test::fresh_directory("rtl_systemc_mem");
  delta::golden::write_export(q, mem_dir);
  std::vector<delta::golden::RawInput> vectors = delta::golden::saturation_corners(q);
  delta::test::InputVectors random(q, kVectorSeed);
  while (vectors.size() < 10'000) vectors.push_back(random.next());

  const std::string plusarg = "+delta_mem_dir=" + mem_dir;
  const char* verilator_argv[] = {argv[0], plusarg.c_str()};
  Verilated::commandArgs(2, verilator_argv);
  (void)argc;

  sc_clock clk("clk", 10, SC_NS);
  sc_signal<bool> ap_rst, ap_start, ap_done, ap_idle, ap_ready, y_0_ap_vld, y_1_ap_vld, y_2_ap_vld;
  sc_signal<std::uint32_t> u_0, u_1, u_2, y_0, y_1, y_2;
  Vdelta_network_sc network("network");
  NetworkDriver driver("driver");
  network.ap_clk(clk);
  driver.clk(clk);
#define DELTA_BIND(port) \
  network.port(port);    \
  driver.port(port)
  DELTA_BIND(ap_rst);
  DELTA_BIND(ap_start);
  DELTA_BIND(ap_done);
  DELTA_BIND(ap_idle);
  DELTA_BIND(ap_ready);
  DELTA_BIND(u_0);
  DELTA_BIND(u_1);
  DELTA_BIND(u_2);
  DELTA_BIND(y_0);
  DELTA_BIND(y_1);
  DELTA_BIND(y_2);
  DELTA_BIND(y_0_ap_vld);
  DELTA_BIND(y_1_ap_vld);
  DELTA_BIND(y_2_ap_vld);
#undef DELTA_BIND
  // The model port, unused: the network holds the model of its .mem files (ModelFromFiles).
  sc_signal<bool> model_clk, model_write;
  sc_signal<std::uint32_t> model_address;
  sc_signal<std::uint64_t> model_word;
  network.model_clk_i(model_clk);
  network.model_write_i(model_write);
  network.model_address_i(model_address);
  network.model_word_i(model_word);
  driver.network = &q;
  driver.vectors = &vectors;

  sc_start();
  network.final();
  std::filesystem::remove_all(mem_dir);
  std::cout << driver.compared << " vectors compared, " << driver.mismatches << " mismatches, latency "
            << driver.latency << " cycles\n";
  const bool pass =
      driver.mismatches == 0 && driver.compared == static_cast<long>(vectors.size()) && !Verilated::gotError();
  std::cout << (pass ? "PASS" : "FAIL") << "\n";
  return pass ? 0 : 1;
}
