# Vitis HLS flow of the fixed-point network: C simulation, synthesis, C/RTL co-simulation, IP export.
# NEEDS AMD/Xilinx Vitis HLS (2022.1 or later); not available on this machine and NOT run in CI.
#
# Usage, from the repository root:
#   mkdir -p build/vitis_network
#   build/bin/deltactl quantise --weights weights/paper_like.json --out-dir build/vitis_network --vectors 100000
#   vitis_hls -f scripts/vitis_hls_network.tcl
#
# The same source that compiles here with sc_fixed compiles under Vitis with ap_fixed
# (DELTA_HLS_USE_AP_FIXED selects it in csim; __SYNTHESIS__ in csynth). The testbench compares every
# raw output code with the golden vectors; a mismatch fails csim and cosim.
#
# Part: xc7a35ticsg324-1L (Artix-7 35T, as on Digilent's Arty A7-35), clock 10 ns (100 MHz).
# Expected (not measured here): reuse factor 75, i.e. 2 multipliers by the ALLOCATION limit, so
# about 3 * 25 + 25 * 3 multiply-accumulates in sequence plus the tanh pipeline: roughly 160-250
# cycles (1.6-2.5 us at 100 MHz), a handful of DSP48E1 (products are 16x24 and 18x24 bits), and
# the tanh table and slope (1024 x 20 and 1024 x 14 bits) in BRAM. The port interface (x_0..x_2,
# y_0..y_2 with ap_vld, ap_ctrl_hs) is the one rtl/network/delta_network.sv implements.

set root [file normalize [file dirname [info script]]/..]
set export_dir $root/build/vitis_network
set cflags "-std=c++14 -DDELTA_HLS_USE_AP_FIXED -I$root/hls -I$root/hls/network -I$export_dir"

open_project -reset $root/build/vitis_network/project
set_top delta_network
add_files $root/hls/network/network_top.cpp -cflags $cflags
add_files -tb $root/hls/network/network_top_tb.cpp -cflags $cflags
add_files -tb $export_dir/golden_vectors.txt

open_solution -reset solution_xc7a35t -flow_target vivado
set_part xc7a35ticsg324-1L
create_clock -period 10 -name default

csim_design -argv golden_vectors.txt
csynth_design
cosim_design -argv golden_vectors.txt -rtl verilog
export_design -format ip_catalog -rtl verilog
exit
