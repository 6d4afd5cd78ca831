// Pickles of dicts of float32 numpy arrays (io/pickle_write.h).
#include "io/pickle_write.h"

#include <cstring>
#include <fstream>

#include "core/atomic_file.h"
#include "core/error.h"

namespace haha {

namespace {

class Out {
 public:
  void op(uint8_t c) { b_.push_back(c); }
  void u32(uint32_t v) { for (int k = 0; k < 4; ++k) b_.push_back(uint8_t(v >> (8 * k))); }
  void text(const std::string& s) {  // SHORT_BINUNICODE or BINUNICODE
    if (s.size() < 256) op(0x8c), op(uint8_t(s.size()));
    else op('X'), u32(uint32_t(s.size()));
    b_.insert(b_.end(), s.begin(), s.end());
  }
  void bytes(const uint8_t* p, size_t n) {  // SHORT_BINBYTES or BINBYTES
    if (n < 256) op('C'), op(uint8_t(n));
    else op('B'), u32(uint32_t(n));
    b_.insert(b_.end(), p, p + n);
  }
  void integer(int64_t v) {
    if (v >= 0 && v < 256) op('K'), op(uint8_t(v));
    else op('J'), u32(uint32_t(int32_t(v)));
  }
  void global(const char* module, const char* name) { text(module), text(name), op(0x93); }  // STACK_GLOBAL
  std::vector<uint8_t> take() { return std::move(b_); }

 private:
  std::vector<uint8_t> b_;
};

}  // namespace

std::vector<uint8_t> pickle_float_arrays(const std::vector<PickleArray>& arrays) {
  Out o;
  o.op(0x80), o.op(4);  // PROTO 4
  o.op('}');            // EMPTY_DICT
  o.op('(');            // MARK
  for (const PickleArray& a : arrays) {
    std::vector<int64_t> shape = a.shape.empty() ? std::vector<int64_t>{int64_t(a.values.size())} : a.shape;
    int64_t n = 1;
    for (int64_t d : shape) n *= d;
    if (n != int64_t(a.values.size()) || a.values.size() > (size_t(1) << 28))
      fail("pickle " + a.key, "shape does not match the values");
    o.text(a.key);
    // _reconstruct(ndarray, (0,), b'b')
    o.global("numpy.core.multiarray", "_reconstruct");
    o.global("numpy", "ndarray");
    o.integer(0), o.op(0x85);  // TUPLE1
    const uint8_t b = 'b';
    o.bytes(&b, 1);
    o.op(0x87), o.op('R');  // TUPLE3, REDUCE
    // BUILD state (1, shape, dtype('f4', False, True) + its state, False, data)
    o.op('(');
    o.integer(1);
    o.op('(');
    for (int64_t d : shape) o.integer(d);
    o.op('t');
    o.global("numpy", "dtype");
    o.text("f4"), o.op(0x89), o.op(0x88), o.op(0x87), o.op('R');  // NEWFALSE NEWTRUE TUPLE3 REDUCE
    o.op('('), o.integer(3), o.text("<"), o.op('N'), o.op('N'), o.op('N'), o.integer(-1), o.integer(-1), o.integer(0),
        o.op('t'), o.op('b');  // dtype state, BUILD
    o.op(0x89);                // not Fortran order
    std::vector<uint8_t> raw(a.values.size() * 4);
    if (!raw.empty()) std::memcpy(raw.data(), a.values.data(), raw.size());  // little-endian hosts only (x86, arm)
    o.bytes(raw.data(), raw.size());
    o.op('t'), o.op('b');  // TUPLE, BUILD
  }
  o.op('u');  // SETITEMS
  o.op('.');  // STOP
  return o.take();
}

void write_pickle_float_arrays(const std::string& path, const std::vector<PickleArray>& arrays) {
  const std::vector<uint8_t> bytes = pickle_float_arrays(arrays);
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!f) fail(path, "write failed");
  });
}

}  // namespace haha
