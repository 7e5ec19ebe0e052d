// Exchange of the network with MATLAB (the paper's tool), as a .mat file or a documented CSV.
//
// Variables, named after the fields of MATLAB's network object (net = feedforwardnet(25)):
//   IW          H x 3   net.IW{1,1}
//   b1          H x 1   net.b{1}
//   LW          3 x H   net.LW{2,1}
//   b2          3 x 1   net.b{2}
//   input_xmin  3 x 1   net.inputs{1}.processSettings{1}.xmin   (mapminmax, positions in metres)
//   input_xmax  3 x 1   net.inputs{1}.processSettings{1}.xmax
//   output_xmin 3 x 1   net.outputs{2}.processSettings{1}.xmin  (joint angles in degrees)
//   output_xmax 3 x 1   net.outputs{2}.processSettings{1}.xmax
// mapminmax must use its default target range [-1, 1] and no other processing function may change
// the data (removeconstantrows is harmless on three varying inputs).
//
// .mat: MATLAB level-5 file (what MATLAB's save writes by default, read through libmatio).
// .csv: one line per variable, `name,rows,columns,v1,v2,...` with the values in MATLAB's column-major
// (:) order, as shortest round-trip decimals; lines starting with '#' are comments.
#pragma once

#include <string>

#include "delta/nn/network.hpp"

namespace delta::nn {

// The format follows the extension (.mat or .csv). Written atomically. Throws InputError when the
// file cannot be written, std::invalid_argument for another extension.
void export_matlab(const std::string& path, const Network& network);

// Throws InputError(file, line, reason) for a missing variable, wrong dimensions, non-finite values
// or an empty scaling range.
Network import_matlab(const std::string& path);

}  // namespace delta::nn
