// State memory of the joint controllers: 64 x 32 bits, one synchronous read and one write port
// (maps to two iCE40 SB_RAM40_4K). Read latency: one cycle. A read of the word written in the same
// cycle returns either word: joint_controller never does it (its formal property
// the_memory_never_reads_the_word_written), so yosys builds no bypass for it (no_rw_check; without
// it, yosys 0.23 and 0.55 add 72 flip-flops and 38 LUTs to return the old word).
module joint_state_ram (
  input  logic        clk_i,
  input  logic [5:0]  read_address_i,
  output logic [31:0] read_data_o,
  input  logic        write_enable_i,
  input  logic [5:0]  write_address_i,
  input  logic [31:0] write_data_i
);
  // Address {joint[1:0], bank, slot[2:0]}; public so testbenches can compare every state.
  (* no_rw_check *) logic [31:0] memory_q [64] /*verilator public_flat_rd*/;

  always_ff @(posedge clk_i) begin
    if (write_enable_i) memory_q[write_address_i] <= write_data_i;
    read_data_o <= memory_q[read_address_i];
  end
endmodule
