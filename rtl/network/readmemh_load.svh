// Loads MemDir/MemFile into the array `words` of the including module (readmemh_rom, readmemh_table).
//
// In simulation the plusarg +delta_mem_dir=DIR replaces MemDir, so one Verilated model serves any
// weights, and a missing or unreadable file stops the simulation with $fatal (Verilator only warns
// on a missing $readmemh file). In synthesis yosys itself fails on a missing file.
`ifdef SYNTHESIS
  initial $readmemh({MemDir, "/", MemFile}, words);
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
    $readmemh(path, words);
  end
`endif
