// A minimal, safe reader of Python pickles (protocols 2-5, plus the few protocol-0/1
// opcodes those protocols still emit) for the files body-model fitting tools write:
// dicts of numpy arrays, numpy scalars, floats, ints, strings, bytes, lists, tuples, None,
// bools. Nothing is ever executed: a pickle may only name the globals numpy uses to
// rebuild arrays and dtypes (numpy.core.multiarray._reconstruct / scalar,
// numpy.core.numeric._frombuffer, their numpy._core spellings, numpy.ndarray, numpy.dtype)
// and a few harmless builtins (_codecs.encode for protocol-2 bytes, bytearray,
// collections.OrderedDict). Any other global (a class, os.system, torch tensors), a
// persistent id or an extension code is an error naming the file and the global.
//
// Bounded: every opcode is checked against the end of the buffer; the objects created
// are at most one per opcode; decoded array bytes are capped at a small multiple of the
// input size (so memo references cannot multiply memory). Truncated or corrupt input
// throws haha::Error "<file>: pickle: <problem> at byte N".
//
// Arrays are stored as NpyArray (io/npy.h) in C order, little-endian. Numeric dtypes
// npy.h cannot hold are widened on load (bool/int8/uint8/int16/uint16 -> int32,
// float16 -> float32, uint64 -> int64 when every value fits); other dtypes (strings,
// objects, complex, structured) load as dtype unsupported and are an error only when
// their numbers are asked for.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "io/npy.h"

namespace haha {

enum class PyKind : uint8_t {
  none, boolean, integer, floating, string, bytes, list, tuple, dict, set,
  ndarray,  // numpy array or numpy scalar (a 0-d array)
  dtype,    // numpy dtype object (only meaningful while unpickling)
  global,   // an allowed callable (only meaningful while unpickling)
};

const char* py_kind_name(PyKind k);

// One unpickled object. Objects live in their Pickle's arena; pointers stay valid as
// long as the Pickle does. Containers may share children (memo references).
struct PyObj {
  PyKind kind = PyKind::none;
  bool b = false;                 // boolean
  int64_t i = 0;                  // integer
  double f = 0;                   // floating
  std::string str;                // string (UTF-8) or bytes (raw); for dtype: its name; for global: "module.name"
  std::vector<const PyObj*> items;                          // list, tuple, set
  std::vector<std::pair<const PyObj*, const PyObj*>> entries;  // dict, insertion order
  NpyArray array;                 // ndarray (dtype unsupported for non-numeric dtypes)
  std::string numpy_dtype;        // ndarray: numpy's name of the stored dtype ("<f4", "|b1", "<U5")

  bool is_number() const { return kind == PyKind::boolean || kind == PyKind::integer || kind == PyKind::floating; }
  bool is_text() const { return kind == PyKind::string || kind == PyKind::bytes; }
  // Dict lookup by string (or bytes) key; nullptr when absent or when this is no dict.
  const PyObj* get(std::string_view key) const;
  // String keys of a dict, in insertion order (non-string keys skipped).
  std::vector<std::string> keys() const;
};

// Numbers held by a value: an ndarray, a number, or a (nested, rectangular) list/tuple of
// numbers. `where` names the value in errors ("file.pkl: key").
struct PyNumbers {
  std::vector<double> values;  // C order
  std::vector<int64_t> shape;  // empty for a scalar
};
PyNumbers py_numbers(const PyObj& v, const std::string& where);

class Pickle {
 public:
  // Reads and unpickles a whole file. Errors name `path`.
  static Pickle read(const std::string& path);
  // Unpickles a buffer; `where` names it in errors.
  static Pickle parse(const uint8_t* data, size_t size, const std::string& where);

  Pickle(Pickle&&) = default;
  Pickle& operator=(Pickle&&) = default;

  const PyObj& root() const { return *root_; }
  const std::string& where() const { return where_; }

  // root()[key] of a dict pickle; nullptr when absent. Throws if the root is no dict.
  const PyObj* find(const std::string& key) const;
  // Numbers of root()[key]; throws "where: key: missing" when absent.
  PyNumbers numbers(const std::string& key) const;

 private:
  Pickle() = default;
  friend class PickleParser;
  std::vector<std::unique_ptr<PyObj>> arena_;
  const PyObj* root_ = nullptr;
  std::string where_;
};

}  // namespace haha
