// A few constant words loaded from a $readmemh file, all readable at once (LUT constants, no RAM).
//
// The file is MemDir/MemFile (+delta_mem_dir=DIR in simulation; a missing file is fatal, see
// readmemh_load.svh). In synthesis the words are constants, so logic using them folds.
module readmemh_table #(
  parameter int unsigned Depth   = 3,
  parameter int unsigned Width   = 16,
  parameter              MemDir  = ".",
  parameter              MemFile = "table.mem"
) (
  output logic [Depth*Width-1:0] words_o  // word k at [k*Width +: Width]
);
  logic [Width-1:0] words [Depth];
`include "readmemh_load.svh"

  for (genvar k = 0; k < Depth; k++) begin : g_word
    assign words_o[k*Width +: Width] = words[k];
  end
endmodule
