// A memory of the model (the network's weights and biases): one registered read port in the
// network's clock (1 cycle latency) and one write port in the board's clock, through which the
// board's model loader writes the words of a load (rtl/board/model_loader.sv). iCE40 block RAMs
// have separate read and write clocks, so the two ports are one SB_RAM40_4K's.
//
// InitFromFile = 1 (the standalone network: its tests, `ik --backend rtl`, its gate-level netlist):
// the memory holds MemDir/MemFile's words from address FileAddress on ($readmemh; +delta_mem_dir=DIR
// in simulation, a missing file fatal, as readmemh_load.svh; the other words are never read). InitFromFile = 0
// (the board): it starts at zero, and the model comes only through the write port.
module model_ram #(
  parameter int unsigned Depth        = 32,
  parameter int unsigned Width        = 16,
  parameter bit          InitFromFile = 1'b1,
  parameter              MemDir       = ".",
  parameter              MemFile      = "ram.mem",
  parameter int unsigned FileAddress  = 0,
  localparam int unsigned AddressWidth = (Depth > 1) ? $clog2(Depth) : 1
) (
  input  logic                    clk_i,
  input  logic [AddressWidth-1:0] address_i,
  output logic [Width-1:0]        data_o,          // words[address_i] of the previous cycle
  input  logic                    write_clk_i,
  input  logic                    write_i,
  input  logic [AddressWidth-1:0] write_address_i,
  input  logic [Width-1:0]        write_data_i
);
  // no_rw_check: the two ports are in different clocks; a word the network reads while the loader
  // writes it is never used (the drives are off during a load, so the network is not started).
  (* ram_style = "block", no_rw_check *) logic [Width-1:0] words [Depth];
  if (!InitFromFile) begin : g_zero
    initial begin
      for (int i = 0; i < Depth; i++) words[i] = '0;
    end
  end else begin : g_file
`ifdef SYNTHESIS
    initial $readmemh({MemDir, "/", MemFile}, words, FileAddress);
`else
    initial begin : load
      string directory;
      string path;
      int    file;
      directory = MemDir;
      if ($value$plusargs("delta_mem_dir=%s", directory)) begin
        // directory now holds the plusarg's value
      end
      path = {directory, "/", MemFile};
      file = $fopen(path, "r");
      if (file == 0) $fatal(1, "%m: cannot open %s", path);
      $fclose(file);
      $readmemh(path, words, FileAddress);
    end
`endif
  end

  always_ff @(posedge write_clk_i) begin
    if (write_i) words[write_address_i] <= write_data_i;
  end
  always_ff @(posedge clk_i) begin
    data_o <= words[address_i];
  end
endmodule
