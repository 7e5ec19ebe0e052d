# The yosys synthesis command of the iCE40 UP5K, one home for the bitstream (fpga_flow.sh) and the
# gate-level models the tests run (gate_level_netlist.sh): the netlist tested is the one flashed.
# -abc9: ABC's timing-driven mapping with the carry and LUT delays (about 45 fewer logic cells on
# the board than the default mapping; the UP5K is 99 % full), without its final &mfs step (Debian's
# ABC aborts in it on this design: Gia_ManInsertMfs assertion). Sourced, not run.
ice40_synth="scratchpad -set abc9.nomfs 1; synth_ice40 -dsp -abc9"
