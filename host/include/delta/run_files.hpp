// The files one run of deltactl reads and writes, so that no output destroys an input or another
// output: the same file under two names (a link, a relative path) is caught by device and inode.
#pragma once

#include <string>

namespace delta {

// The registry is kept only once enabled: deltactl's main enables it for its one run; a program
// that reads and later rewrites a file in several steps (tests, tools) is not held to one run.
void track_run_files(bool enabled);

// Called by open_input_file: throws InputError if the file is an output of this run.
void note_input_file(const std::string& path);

// Called by OutputFile for a regular (or not yet existing) target: throws InputError if the file
// is an input or an output still being written in this run. Devices and pipes may be named more than once.
void note_output_file(const std::string& path);

// Called when that OutputFile is gone (committed or not): reading it afterwards is legitimate.
void forget_output_file(const std::string& path);

// Forgets every file (tests run several commands in one process).
void forget_run_files();

}  // namespace delta
