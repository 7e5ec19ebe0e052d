// Read-only memory loaded from a $readmemh file, one registered read port (1 cycle latency).
//
// The file is MemDir/MemFile (+delta_mem_dir=DIR in simulation; a missing file is fatal, see
// readmemh_load.svh). The registered read and `ram_style = "block"` put every ROM in iCE40 block
// RAM: left to its cost model, yosys 0.23 builds the small weight and tanh ROMs from about 500
// LUT4s, which the device has no room for.
module readmemh_rom #(
  parameter int unsigned Depth   = 32,
  parameter int unsigned Width   = 16,
  parameter              MemDir  = ".",
  parameter              MemFile = "rom.mem",
  localparam int unsigned AddressWidth = (Depth > 1) ? $clog2(Depth) : 1
) (
  input  logic                    clk_i,
  input  logic [AddressWidth-1:0] address_i,
  output logic [Width-1:0]        data_o     // words[address_i] of the previous cycle
);
  (* ram_style = "block" *) logic [Width-1:0] words [Depth];
`include "readmemh_load.svh"

  always_ff @(posedge clk_i) begin
    data_o <= words[address_i];
  end
endmodule
