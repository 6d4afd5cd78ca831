// Writing Python pickles of the one kind fitting tools produce and our readers take: a
// dict of float32 numpy arrays (io/pickle.h reads them back). The bytes follow what
// `pickle.dump(dict_of_numpy_arrays, f)` writes with protocol 4 (numpy's
// numpy.core.multiarray._reconstruct + BUILD of (version, shape, dtype('f4'), False, raw
// bytes) per array), without the memo entries, which only deduplicate. Used to write
// X-Humans-layout SMPL-X fits (data/xhumans_take.h).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace haha {

struct PickleArray {
  std::string key;
  std::vector<float> values;
  std::vector<int64_t> shape;  // empty: 1-D of values.size()
};

std::vector<uint8_t> pickle_float_arrays(const std::vector<PickleArray>& arrays);
void write_pickle_float_arrays(const std::string& path, const std::vector<PickleArray>& arrays);  // atomic

}  // namespace haha
