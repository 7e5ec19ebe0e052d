# Vitis HLS flow of the three joint controllers: C simulation, synthesis, C/RTL co-simulation, IP export.
# NEEDS AMD/Xilinx Vitis HLS (2022.1 or later); not available on this machine and NOT run here or in
# CI. What runs here is the same top and testbench on sc_fixed (CTest JointHlsTop.MatchesGoldenVectors).
#
# Usage, from the repository root (the generator is built by `cmake --build build --target joint_golden_vectors`):
#   mkdir -p build/vitis_joint
#   build/tests/joint_golden_vectors build/vitis_joint 100000 20261121
#   vitis_hls -f scripts/vitis_hls_joint.tcl
# The generator writes joint_coefficients.hpp (the coefficient codes of the golden model,
# delta::golden::make_fixed_coefficients) and joint_golden_vectors.txt (100,000 closed-loop periods).
#
# The same source that compiles here with sc_fixed compiles under Vitis with ap_fixed
# (DELTA_HLS_USE_AP_FIXED selects it in csim; __SYNTHESIS__ in csynth). The testbench compares every
# output code, and in csim every state code and the compiled-in coefficients, with the golden
# vectors; a mismatch fails csim and cosim. Cosim compares the ports only (--ports-only): there the
# states live in the RTL.
#
# Part: xc7a35ticsg324-1L (Artix-7 35T, as on Digilent's Arty A7-35), clock 10 ns (100 MHz).
# Not synthesised here: no latency or resource figure is claimed for this top. The port interface
# (reference_0..2, encoder_0..2, current_0..2 with ap_vld, limited, overflow_count, ap_ctrl_hs) is the one
# rtl/joint/joint_controller.sv implements (bit-serial there, 892 cycles).

set root [file normalize [file dirname [info script]]/..]
set export_dir $root/build/vitis_joint
set cflags "-std=c++14 -DDELTA_HLS_USE_AP_FIXED -I$root/hls -I$root/hls/joint -I$export_dir"

open_project -reset $root/build/vitis_joint/project
set_top joint_top
add_files $root/hls/joint/joint_top.cpp -cflags $cflags
add_files -tb $root/hls/joint/joint_top_tb.cpp -cflags $cflags
add_files -tb $export_dir/joint_golden_vectors.txt

open_solution -reset solution_xc7a35t -flow_target vivado
set_part xc7a35ticsg324-1L
create_clock -period 10 -name default
# ap_rst also clears the static states (primed, overflow count), as the RTL's reset does.
config_rtl -reset state

csim_design -argv joint_golden_vectors.txt
csynth_design
cosim_design -argv {joint_golden_vectors.txt --ports-only} -rtl verilog
export_design -format ip_catalog -rtl verilog
exit
