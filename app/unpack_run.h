// `haha unpack`'s driver: a .glb avatar -> plain files in DIR:
//   texture.<png|jpg|webp>  the embedded image, byte for byte
//   mesh.obj                rest-pose body (subject's shape) with its UV map
//   gaussians.ply           the Gaussians in the rest pose as a standard 3DGS .ply
//   summary.json            counts, sizes, quantization, storage report (as `haha info --json`)
//   avatar.npz, body.npz, config.json   a run directory again: `haha pack DIR` repacks it
#pragma once

#include <string>

namespace haha {

// Reads and validates `in` (format/avatar_unpack.h), writes the files into `out` (created
// when missing) and prints one line. Throws haha::Error naming the file.
void run_unpack(const std::string& in, const std::string& out);

}  // namespace haha
