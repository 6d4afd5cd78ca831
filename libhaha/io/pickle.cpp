#include "io/pickle.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "core/error.h"

namespace haha {

const char* py_kind_name(PyKind k) {
  switch (k) {
    case PyKind::none: return "None";
    case PyKind::boolean: return "bool";
    case PyKind::integer: return "int";
    case PyKind::floating: return "float";
    case PyKind::string: return "str";
    case PyKind::bytes: return "bytes";
    case PyKind::list: return "list";
    case PyKind::tuple: return "tuple";
    case PyKind::dict: return "dict";
    case PyKind::set: return "set";
    case PyKind::ndarray: return "numpy array";
    case PyKind::dtype: return "numpy dtype";
    case PyKind::global: return "global";
  }
  return "?";
}

const PyObj* PyObj::get(std::string_view key) const {
  if (kind != PyKind::dict) return nullptr;
  for (const auto& [k, v] : entries)
    if (k->is_text() && k->str == key) return v;
  return nullptr;
}

std::vector<std::string> PyObj::keys() const {
  std::vector<std::string> out;
  for (const auto& [k, v] : entries)
    if (k->is_text()) out.push_back(k->str);
  return out;
}

namespace {

constexpr int kMaxNestingDepth = 64;                // nested lists in py_numbers
constexpr uint64_t kMaxListElements = uint64_t(1) << 24;  // list elements walked by py_numbers

// Appends the numbers of a (nested) list/tuple, checking it is rectangular: the first
// list met at each depth fixes that dimension, every later one must match it.
// `visits` bounds the walk: shared references (memo) can make a small pickle a huge DAG.
void collect_numbers(const PyObj& v, const std::string& where, size_t level, PyNumbers& out, uint64_t& visits) {
  if (level > size_t(kMaxNestingDepth)) fail(where, "lists nested too deeply");
  if (++visits > kMaxListElements) fail(where, "list holds too many elements");
  const bool zero_d_array = v.kind == PyKind::ndarray && v.array.shape.empty();
  if (v.is_number() || zero_d_array) {
    if (level != out.shape.size()) fail(where, "ragged nested list (not a rectangular array)");
    if (zero_d_array) {
      if (v.array.dtype == DType::unsupported)
        fail(where, "numpy scalar of dtype '" + v.numpy_dtype + "' is not a number");
      out.values.push_back(v.array.as_double()[0]);
    } else {
      out.values.push_back(v.kind == PyKind::floating ? v.f : double(v.kind == PyKind::boolean ? int64_t(v.b) : v.i));
    }
    return;
  }
  if (v.kind == PyKind::list || v.kind == PyKind::tuple) {
    const int64_t n = int64_t(v.items.size());
    if (level == out.shape.size()) {
      if (!out.values.empty()) fail(where, "ragged nested list (not a rectangular array)");
      out.shape.push_back(n);
    } else if (level > out.shape.size() || out.shape[level] != n) {
      fail(where, "ragged nested list (not a rectangular array)");
    }
    for (const PyObj* it : v.items) collect_numbers(*it, where, level + 1, out, visits);
    return;
  }
  if (v.kind == PyKind::ndarray) fail(where, "a list of numpy arrays is not supported");
  fail(where, std::string("expected numbers, found ") + py_kind_name(v.kind));
}

}  // namespace

PyNumbers py_numbers(const PyObj& v, const std::string& where) {
  PyNumbers out;
  if (v.kind == PyKind::ndarray) {
    if (v.array.dtype == DType::unsupported)
      fail(where, "numpy array of dtype '" + v.numpy_dtype + "' holds no numbers");
    out.values = v.array.as_double();
    out.shape = v.array.shape;
    return out;
  }
  uint64_t visits = 0;
  collect_numbers(v, where, 0, out, visits);
  // Rectangularity: total count must equal the product of the dimensions found.
  int64_t n = 1;
  for (int64_t d : out.shape) n *= d;
  if (n != int64_t(out.values.size())) fail(where, "ragged nested list (not a rectangular array)");
  return out;
}

const PyObj* Pickle::find(const std::string& key) const {
  if (root_->kind != PyKind::dict)
    fail(where_, std::string("pickle holds a ") + py_kind_name(root_->kind) + ", expected a dict");
  return root_->get(key);
}

PyNumbers Pickle::numbers(const std::string& key) const {
  const PyObj* v = find(key);
  if (!v) fail(where_, key + ": missing");
  return py_numbers(*v, where_ + ": " + key);
}

// ---------------------------------------------------------------------------------------
// The unpickler.

enum class Global : int64_t {
  reconstruct,   // numpy.core.multiarray._reconstruct
  ndarray,       // numpy.ndarray
  dtype,         // numpy.dtype
  scalar,        // numpy.core.multiarray.scalar
  frombuffer,    // numpy.core.numeric._frombuffer
  codecs_encode, // _codecs.encode (protocol-2 bytes)
  bytearray,     // builtins.bytearray
  ordered_dict,  // collections.OrderedDict
};

struct DtypeInfo {
  char kind = '?';    // numpy kind letter: f i u b c U S O V M m
  int itemsize = 0;   // bytes
  char order = '|';   // < > | =
  bool structured = false;
  std::string name;   // as given to numpy.dtype(), e.g. "f4"
  std::string descr() const {
    std::string o(1, itemsize == 1 ? '|' : (order == '=' ? '<' : order));
    return o + kind + std::to_string(itemsize);
  }
};

class PickleParser {
 public:
  PickleParser(const uint8_t* data, size_t size, std::string where)
      : p_(data), n_(size), where_(std::move(where)),
        array_budget_(8 * uint64_t(size) + (uint64_t(1) << 20)) {}

  Pickle run();

 private:
  const uint8_t* p_;
  size_t n_;
  size_t pos_ = 0;
  size_t op_pos_ = 0;  // start of the current opcode, for error messages
  std::string where_;
  uint64_t array_budget_;  // bytes of array data still allowed

  Pickle out_;
  std::vector<PyObj*> stack_;
  std::vector<size_t> marks_;
  std::unordered_map<uint64_t, PyObj*> memo_;
  std::unordered_set<const PyObj*> pending_arrays_;  // from _reconstruct, awaiting BUILD
  std::unordered_map<const PyObj*, DtypeInfo> dtypes_;
  std::unordered_map<const PyObj*, bool> frozen_;    // tuples/frozensets are immutable

  [[noreturn]] void error(const std::string& what) const {
    fail(where_, "pickle: " + what + " at byte " + std::to_string(op_pos_));
  }

  PyObj* make(PyKind k) {
    out_.arena_.push_back(std::make_unique<PyObj>());
    out_.arena_.back()->kind = k;
    return out_.arena_.back().get();
  }

  // --- reading raw input ---
  void need(size_t k) {
    if (k > n_ - pos_) error("truncated (needs " + std::to_string(k) + " more bytes, " +
                             std::to_string(n_ - pos_) + " left)");
  }
  uint8_t u8() { need(1); return p_[pos_++]; }
  uint64_t uint_le(int bytes) {
    need(size_t(bytes));
    uint64_t v = 0;
    for (int k = 0; k < bytes; ++k) v |= uint64_t(p_[pos_ + size_t(k)]) << (8 * k);
    pos_ += size_t(bytes);
    return v;
  }
  std::string raw(uint64_t len) {
    if (len > n_ - pos_) error("truncated (a " + std::to_string(len) + "-byte string, " +
                               std::to_string(n_ - pos_) + " bytes left)");
    std::string s(reinterpret_cast<const char*>(p_ + pos_), size_t(len));
    pos_ += size_t(len);
    return s;
  }
  std::string line() {
    const void* nl = std::memchr(p_ + pos_, '\n', n_ - pos_);
    if (!nl) error("truncated (unterminated text argument)");
    const size_t len = size_t(static_cast<const uint8_t*>(nl) - (p_ + pos_));
    std::string s(reinterpret_cast<const char*>(p_ + pos_), len);
    pos_ += len + 1;
    if (!s.empty() && s.back() == '\r') s.pop_back();
    return s;
  }

  // --- stack ---
  void push(PyObj* o) { stack_.push_back(o); }
  PyObj* pop() {
    if (stack_.empty() || (!marks_.empty() && stack_.size() <= marks_.back())) error("stack underflow");
    PyObj* o = stack_.back();
    stack_.pop_back();
    return o;
  }
  PyObj* top() {
    if (stack_.empty() || (!marks_.empty() && stack_.size() <= marks_.back())) error("stack underflow");
    return stack_.back();
  }
  std::vector<PyObj*> pop_mark() {
    if (marks_.empty()) error("MARK expected but none is open");
    const size_t m = marks_.back();
    marks_.pop_back();
    std::vector<PyObj*> items(stack_.begin() + std::ptrdiff_t(m), stack_.end());
    stack_.resize(m);
    return items;
  }

  // --- object helpers ---
  PyObj* make_int(int64_t v) { PyObj* o = make(PyKind::integer); o->i = v; return o; }
  PyObj* make_text(PyKind k, std::string s) { PyObj* o = make(k); o->str = std::move(s); return o; }
  PyObj* make_tuple(const std::vector<PyObj*>& items) {
    PyObj* o = make(PyKind::tuple);
    o->items.assign(items.begin(), items.end());
    return o;
  }
  int64_t long_from_bytes(const std::string& b) {
    if (b.empty()) return 0;
    if (b.size() > 8) {
      // Accept redundant sign bytes (e.g. 2**63-1 needs no 9th byte, but -1 padded does).
      const uint8_t fill = (uint8_t(b[7]) & 0x80) ? 0xff : 0x00;
      for (size_t k = 8; k < b.size(); ++k)
        if (uint8_t(b[k]) != fill) error("integer does not fit in 64 bits");
    }
    uint64_t v = 0;
    const size_t m = std::min<size_t>(b.size(), 8);
    for (size_t k = 0; k < m; ++k) v |= uint64_t(uint8_t(b[k])) << (8 * k);
    if (m < 8 && (uint8_t(b[m - 1]) & 0x80)) v |= ~uint64_t(0) << (8 * m);  // sign-extend
    return int64_t(v);
  }
  void memo_put(uint64_t idx, PyObj* o) {
    if (memo_.size() > n_) error("memo larger than the input");
    memo_[idx] = o;
  }
  PyObj* memo_get(uint64_t idx) {
    auto it = memo_.find(idx);
    if (it == memo_.end()) error("memo key " + std::to_string(idx) + " was never stored");
    return it->second;
  }

  void resolve_global(const std::string& module, const std::string& name);
  void reduce();
  void build();
  void set_items(PyObj* dict, const std::vector<PyObj*>& kv);
  PyObj* make_dtype(const PyObj& args);
  void fill_array(PyObj* arr, const DtypeInfo& dt, const PyObj& shape_obj, bool fortran, const PyObj& data);
  std::string bytes_of(const PyObj& o, const char* what);

  // Opcode groups of run(): each returns false for an opcode outside its group.
  bool stack_op(uint8_t op);
  bool push_constant_op(uint8_t op);
  bool container_op(uint8_t op);
  bool memo_op(uint8_t op);
  bool object_op(uint8_t op);
  [[noreturn]] void refuse_op(uint8_t op);  // refused and unknown opcodes
};

void PickleParser::resolve_global(const std::string& module, const std::string& name) {
  static const std::pair<const char*, Global> table[] = {
      {"numpy.core.multiarray._reconstruct", Global::reconstruct},
      {"numpy._core.multiarray._reconstruct", Global::reconstruct},
      {"numpy.core.multiarray.scalar", Global::scalar},
      {"numpy._core.multiarray.scalar", Global::scalar},
      {"numpy.core.numeric._frombuffer", Global::frombuffer},
      {"numpy._core.numeric._frombuffer", Global::frombuffer},
      {"numpy.ndarray", Global::ndarray},
      {"numpy.dtype", Global::dtype},
      {"_codecs.encode", Global::codecs_encode},
      {"builtins.bytearray", Global::bytearray},
      {"builtins.bytes", Global::bytearray},  // protocol 2 writes b'' as bytes()
      {"__builtin__.bytes", Global::bytearray},
      {"__builtin__.bytearray", Global::bytearray},
      {"collections.OrderedDict", Global::ordered_dict},
  };
  const std::string full = module + "." + name;
  for (const auto& [n, g] : table) {
    if (full == n) {
      PyObj* o = make(PyKind::global);
      o->str = full;
      o->i = int64_t(g);
      push(o);
      return;
    }
  }
  std::string hint;
  if (module.rfind("torch", 0) == 0) hint = " (torch tensors are not supported: save numpy arrays instead)";
  error("refers to global '" + full + "', which is not allowed (only numpy arrays, dtypes and plain "
        "Python values are read; nothing is executed)" + hint);
}

std::string PickleParser::bytes_of(const PyObj& o, const char* what) {
  if (o.kind == PyKind::bytes || o.kind == PyKind::string) return o.str;
  error(std::string(what) + " must be bytes, found " + py_kind_name(o.kind));
}

PyObj* PickleParser::make_dtype(const PyObj& args) {
  // numpy.dtype(name, align, copy); the byte order arrives later through BUILD.
  if (args.kind != PyKind::tuple || args.items.empty() || !args.items[0]->is_text())
    error("numpy.dtype() called without a type name");
  DtypeInfo dt;
  dt.name = args.items[0]->str;
  std::string s = dt.name;
  if (!s.empty() && (s[0] == '<' || s[0] == '>' || s[0] == '|' || s[0] == '=')) {
    dt.order = s[0];
    s = s.substr(1);
  }
  if (s.empty()) error("numpy.dtype() with an empty type name");
  dt.kind = s[0];
  dt.itemsize = 0;
  if (s.size() > 1) {
    for (size_t k = 1; k < s.size(); ++k) {
      if (s[k] < '0' || s[k] > '9' || dt.itemsize > 1'000'000) { dt.kind = 'V'; dt.itemsize = 0; break; }
      dt.itemsize = dt.itemsize * 10 + (s[k] - '0');
    }
  }
  if (dt.itemsize > 1 && dt.order == '|') dt.order = '<';
  PyObj* o = make(PyKind::dtype);
  o->str = dt.name;
  dtypes_[o] = dt;
  return o;
}

void PickleParser::fill_array(PyObj* arr, const DtypeInfo& dt, const PyObj& shape_obj, bool fortran,
                              const PyObj& data) {
  std::vector<int64_t> shape;
  if (shape_obj.kind == PyKind::integer) {
    shape.push_back(shape_obj.i);
  } else if (shape_obj.kind == PyKind::tuple || shape_obj.kind == PyKind::list) {
    for (const PyObj* d : shape_obj.items) {
      if (d->kind != PyKind::integer) error("array shape holds a " + std::string(py_kind_name(d->kind)));
      shape.push_back(d->i);
    }
  } else {
    error(std::string("array shape is a ") + py_kind_name(shape_obj.kind));
  }
  if (shape.size() > 32) error("array has more than 32 dimensions");
  uint64_t count = 1;
  for (int64_t d : shape) {
    if (d < 0) error("negative array dimension");
    if (d > 0 && count > (uint64_t(1) << 48) / uint64_t(d)) error("array too large");
    count *= uint64_t(d);
  }
  arr->array = NpyArray{};
  arr->array.shape = shape;
  arr->numpy_dtype = dt.descr();

  // Map the stored dtype onto one npy.h holds.
  const char k = dt.kind;
  const int sz = dt.itemsize;
  DType out = DType::unsupported;
  int out_size = 0;
  if (!dt.structured) {
    if (k == 'f' && (sz == 4 || sz == 2)) { out = DType::f32; out_size = 4; }
    else if (k == 'f' && sz == 8) { out = DType::f64; out_size = 8; }
    else if ((k == 'i' && sz <= 4 && (sz == 1 || sz == 2 || sz == 4)) || (k == 'u' && (sz == 1 || sz == 2)) ||
             (k == 'b' && sz == 1)) { out = DType::i32; out_size = 4; }
    else if (k == 'u' && sz == 4) { out = DType::u32; out_size = 4; }
    else if ((k == 'i' || k == 'u') && sz == 8) { out = DType::i64; out_size = 8; }
  }
  if (out == DType::unsupported) {
    arr->array.dtype = DType::unsupported;
    arr->array.descr = dt.descr();
    return;  // strings, objects, complex...: kept as a shape only
  }
  const std::string bytes = bytes_of(data, "array data");
  if (uint64_t(bytes.size()) != count * uint64_t(sz))
    error("array data has " + std::to_string(bytes.size()) + " bytes, shape " + shape_string(shape) +
          " of '" + dt.descr() + "' needs " + std::to_string(count * uint64_t(sz)));
  const uint64_t out_bytes = count * uint64_t(out_size);
  if (out_bytes > array_budget_) error("array data exceeds what the input can hold (repeated references?)");
  array_budget_ -= out_bytes;

  const bool swap = dt.order == '>' && sz > 1;
  auto load = [&](uint64_t idx, uint8_t* dst) {  // element idx of the source -> converted dst
    uint8_t b[8];
    std::memcpy(b, bytes.data() + idx * uint64_t(sz), size_t(sz));
    if (swap) std::reverse(b, b + sz);
    uint64_t u = 0;
    for (int j = 0; j < sz; ++j) u |= uint64_t(b[j]) << (8 * j);
    if (k == 'f' && sz == 2) {  // IEEE half -> float
      const uint32_t sign = uint32_t(u >> 15) & 1, e = uint32_t(u >> 10) & 31, m = uint32_t(u) & 1023;
      float f;
      if (e == 0) f = std::ldexp(float(m), -24);
      else if (e == 31) f = m ? std::numeric_limits<float>::quiet_NaN() : std::numeric_limits<float>::infinity();
      else f = std::ldexp(float(m + 1024), int(e) - 25);
      if (sign) f = -f;
      std::memcpy(dst, &f, 4);
    } else if (out == DType::i32 && sz < 4) {
      int32_t v;
      if (k == 'i') v = sz == 1 ? int32_t(int8_t(u)) : int32_t(int16_t(u));
      else v = int32_t(u);
      std::memcpy(dst, &v, 4);
    } else if (k == 'u' && sz == 8) {
      if (u > uint64_t(std::numeric_limits<int64_t>::max())) error("uint64 array value exceeds int64");
      std::memcpy(dst, &u, 8);
    } else {
      std::memcpy(dst, &u, size_t(sz));  // same width, now little-endian
    }
  };

  arr->array.dtype = out;
  arr->array.descr = out == DType::f32 ? "<f4" : out == DType::f64 ? "<f8" : out == DType::i32 ? "<i4"
                                                 : out == DType::u32 ? "<u4" : "<i8";
  arr->array.bytes.resize(size_t(out_bytes));
  uint8_t* dst = arr->array.bytes.data();
  if (!fortran || shape.size() < 2) {
    for (uint64_t e = 0; e < count; ++e) load(e, dst + e * uint64_t(out_size));
  } else {
    // Source is column-major: walk the C-order index, track the Fortran offset.
    const size_t nd = shape.size();
    std::vector<int64_t> idx(nd, 0);
    std::vector<uint64_t> fstride(nd, 1);
    for (size_t d = 1; d < nd; ++d) fstride[d] = fstride[d - 1] * uint64_t(shape[d - 1]);
    for (uint64_t e = 0; e < count; ++e) {
      uint64_t off = 0;
      for (size_t d = 0; d < nd; ++d) off += uint64_t(idx[d]) * fstride[d];
      load(off, dst + e * uint64_t(out_size));
      for (size_t d = nd; d-- > 0;) {
        if (++idx[d] < shape[d]) break;
        idx[d] = 0;
      }
    }
  }
}

void PickleParser::reduce() {
  PyObj* args = pop();
  PyObj* fn = pop();
  if (fn->kind != PyKind::global) error(std::string("REDUCE on a ") + py_kind_name(fn->kind));
  if (args->kind != PyKind::tuple) error("REDUCE arguments are not a tuple");
  const auto& a = args->items;
  switch (Global(fn->i)) {
    case Global::reconstruct: {
      if (a.size() != 3 || a[0]->kind != PyKind::global || Global(a[0]->i) != Global::ndarray)
        error("numpy _reconstruct of something other than numpy.ndarray");
      PyObj* arr = make(PyKind::ndarray);
      pending_arrays_.insert(arr);
      push(arr);
      return;
    }
    case Global::dtype:
      push(make_dtype(*args));
      return;
    case Global::scalar: {
      if (a.size() != 2 || a[0]->kind != PyKind::dtype) error("numpy scalar() needs (dtype, bytes)");
      PyObj* arr = make(PyKind::ndarray);
      PyObj empty_shape;
      empty_shape.kind = PyKind::tuple;
      const DtypeInfo& dt = dtypes_.at(a[0]);
      if (dt.kind == 'O') {  // object scalar: the value itself; not a number we read
        arr->array.dtype = DType::unsupported;
        arr->numpy_dtype = "|O";
      } else {
        fill_array(arr, dt, empty_shape, false, *a[1]);
      }
      push(arr);
      return;
    }
    case Global::frombuffer: {
      // _frombuffer(buffer, dtype, shape, order)
      if (a.size() != 4 || a[1]->kind != PyKind::dtype || !a[3]->is_text())
        error("numpy _frombuffer needs (buffer, dtype, shape, order)");
      PyObj* arr = make(PyKind::ndarray);
      fill_array(arr, dtypes_.at(a[1]), *a[2], a[3]->str == "F", *a[0]);
      push(arr);
      return;
    }
    case Global::codecs_encode: {
      // Protocol 2 writes bytes as _codecs.encode(text, 'latin1'): code points < 256.
      if (a.size() != 2 || a[0]->kind != PyKind::string || !a[1]->is_text() ||
          (a[1]->str != "latin1" && a[1]->str != "latin-1"))
        error("_codecs.encode other than (str, 'latin1')");
      const std::string& s = a[0]->str;
      std::string outb;
      outb.reserve(s.size());
      for (size_t k = 0; k < s.size();) {
        const uint8_t c = uint8_t(s[k]);
        if (c < 0x80) { outb.push_back(char(c)); ++k; }
        else if ((c & 0xE0) == 0xC0 && k + 1 < s.size()) {
          const uint32_t cp = (uint32_t(c & 0x1F) << 6) | (uint8_t(s[k + 1]) & 0x3F);
          if (cp > 0xFF) error("_codecs.encode: character beyond latin1");
          outb.push_back(char(uint8_t(cp)));
          k += 2;
        } else {
          error("_codecs.encode: character beyond latin1");
        }
      }
      push(make_text(PyKind::bytes, std::move(outb)));
      return;
    }
    case Global::bytearray: {
      if (a.empty()) { push(make_text(PyKind::bytes, "")); return; }
      if (a[0]->kind == PyKind::bytes && a.size() == 1) { push(make_text(PyKind::bytes, a[0]->str)); return; }
      // bytearray(text, 'latin-1') as protocol 2 writes it: reuse the codecs path.
      PyObj* g = make(PyKind::global);
      g->i = int64_t(Global::codecs_encode);
      push(g);
      push(args);
      reduce();
      return;
    }
    case Global::ordered_dict: {
      PyObj* d = make(PyKind::dict);
      if (!a.empty()) {
        if (a.size() != 1 || (a[0]->kind != PyKind::list && a[0]->kind != PyKind::tuple))
          error("OrderedDict() with unexpected arguments");
        for (const PyObj* kv : a[0]->items) {
          if ((kv->kind != PyKind::list && kv->kind != PyKind::tuple) || kv->items.size() != 2)
            error("OrderedDict() items are not pairs");
          d->entries.emplace_back(kv->items[0], kv->items[1]);
        }
      }
      push(d);
      return;
    }
    case Global::ndarray:
      error("numpy.ndarray called directly");
  }
  error("REDUCE of an unknown callable");
}

void PickleParser::build() {
  PyObj* state = pop();
  PyObj* obj = top();
  if (obj->kind == PyKind::dtype) {
    // (version, byteorder, subarray, names, fields, elsize, alignment, flags[, metadata])
    DtypeInfo& dt = dtypes_.at(obj);
    if (state->kind != PyKind::tuple || state->items.size() < 8) error("numpy dtype state is not a tuple of 8+");
    const auto& s = state->items;
    if (s[1]->is_text() && s[1]->str.size() == 1) dt.order = s[1]->str[0];
    if (s[2]->kind != PyKind::none || s[3]->kind != PyKind::none) dt.structured = true;
    if (s[5]->kind == PyKind::integer && s[5]->i > 0) dt.itemsize = int(std::min<int64_t>(s[5]->i, 1'000'000));
    if (dt.itemsize > 1 && dt.order == '|') dt.order = '<';
    return;
  }
  if (obj->kind == PyKind::ndarray && pending_arrays_.count(obj)) {
    // (version, shape, dtype, is_fortran, rawdata) or the old 4-tuple without version.
    if (state->kind != PyKind::tuple || (state->items.size() != 5 && state->items.size() != 4))
      error("numpy array state is not a tuple of 4 or 5");
    const size_t o = state->items.size() == 5 ? 1 : 0;
    const PyObj* shape = state->items[o];
    const PyObj* dt = state->items[o + 1];
    const PyObj* fortran = state->items[o + 2];
    const PyObj* data = state->items[o + 3];
    if (dt->kind != PyKind::dtype) error("numpy array state without a dtype");
    const bool is_f = fortran->kind == PyKind::boolean ? fortran->b : (fortran->kind == PyKind::integer && fortran->i);
    const DtypeInfo& info = dtypes_.at(dt);
    if (info.kind == 'O' || data->kind == PyKind::list) {
      // Object arrays pickle their elements as a list: keep the shape, no numbers.
      PyObj empty;
      empty.kind = PyKind::bytes;
      DtypeInfo obj_dt = info;
      obj_dt.kind = 'O';
      fill_array(obj, obj_dt, *shape, false, empty);
    } else {
      fill_array(obj, info, *shape, is_f, *data);
    }
    pending_arrays_.erase(obj);
    return;
  }
  error(std::string("BUILD (object state) on a ") + py_kind_name(obj->kind) + ", which is not allowed");
}

void PickleParser::set_items(PyObj* dict, const std::vector<PyObj*>& kv) {
  if (dict->kind != PyKind::dict) error(std::string("SETITEM on a ") + py_kind_name(dict->kind));
  if (kv.size() % 2) error("SETITEMS with an odd number of items");
  for (size_t k = 0; k < kv.size(); k += 2) {
    const PyObj* key = kv[k];
    bool replaced = false;
    if (key->is_text()) {
      for (auto& e : dict->entries)
        if (e.first->kind == key->kind && e.first->str == key->str) { e.second = kv[k + 1]; replaced = true; break; }
    } else if (key->kind == PyKind::integer) {
      for (auto& e : dict->entries)
        if (e.first->kind == PyKind::integer && e.first->i == key->i) { e.second = kv[k + 1]; replaced = true; break; }
    }
    if (!replaced) dict->entries.emplace_back(key, kv[k + 1]);
  }
}

Pickle PickleParser::run() {
  out_.where_ = where_;
  for (;;) {
    op_pos_ = pos_;
    if (pos_ >= n_) error("truncated (no STOP opcode)");
    const uint8_t op = p_[pos_++];
    if (op == '.') {  // STOP
      if (stack_.size() != 1 || !marks_.empty()) error("STOP with " + std::to_string(stack_.size()) + " objects on the stack");
      if (!pending_arrays_.empty()) error("numpy array never received its data (missing BUILD)");
      out_.root_ = stack_.back();
      return std::move(out_);
    }
    if (!stack_op(op) && !push_constant_op(op) && !container_op(op) && !memo_op(op) && !object_op(op)) refuse_op(op);
  }
}

bool PickleParser::stack_op(uint8_t op) {
  switch (op) {
    case 0x80: {  // PROTO
      const uint8_t v = u8();
      if (v > 5) error("unsupported pickle protocol " + std::to_string(v));
      return true;
    }
    case 0x95: uint_le(8); return true;  // FRAME: the whole input is in memory already
    case '(': marks_.push_back(stack_.size()); return true;  // MARK
    case '0': pop(); return true;                            // POP
    case '1': pop_mark(); return true;                       // POP_MARK
    case '2': push(top()); return true;                      // DUP
    default: return false;
  }
}

bool PickleParser::push_constant_op(uint8_t op) {
  switch (op) {
    case 'N': push(make(PyKind::none)); return true;
    case 0x88: { PyObj* o = make(PyKind::boolean); o->b = true; push(o); return true; }   // NEWTRUE
    case 0x89: { PyObj* o = make(PyKind::boolean); o->b = false; push(o); return true; }  // NEWFALSE
    case 'J': push(make_int(int32_t(uint32_t(uint_le(4))))); return true;  // BININT
    case 'K': push(make_int(int64_t(uint_le(1)))); return true;            // BININT1
    case 'M': push(make_int(int64_t(uint_le(2)))); return true;            // BININT2
    case 0x8a: { const uint64_t len = uint_le(1); push(make_int(long_from_bytes(raw(len)))); return true; }  // LONG1
    case 0x8b: {  // LONG4
      const uint64_t len = uint_le(4);
      if (len > 64) error("integer does not fit in 64 bits");
      push(make_int(long_from_bytes(raw(len))));
      return true;
    }
    case 'I': {  // INT (text): also the protocol-0 spelling of True/False
      const std::string s = line();
      if (s == "01" || s == "00") { PyObj* o = make(PyKind::boolean); o->b = s == "01"; push(o); return true; }
      char* end = nullptr;
      errno = 0;
      const long long v = std::strtoll(s.c_str(), &end, 10);
      if (s.empty() || *end || errno) error("bad INT argument '" + s + "'");
      push(make_int(v));
      return true;
    }
    case 'L': {  // LONG (text)
      std::string s = line();
      if (!s.empty() && s.back() == 'L') s.pop_back();
      char* end = nullptr;
      errno = 0;
      const long long v = std::strtoll(s.c_str(), &end, 10);
      if (s.empty() || *end || errno) error("bad LONG argument (or beyond 64 bits)");
      push(make_int(v));
      return true;
    }
    case 'G': {  // BINFLOAT: big-endian double
      need(8);
      uint64_t u = 0;
      for (int k = 0; k < 8; ++k) u = (u << 8) | p_[pos_ + size_t(k)];
      pos_ += 8;
      PyObj* o = make(PyKind::floating);
      std::memcpy(&o->f, &u, 8);
      push(o);
      return true;
    }
    case 'F': {  // FLOAT (text)
      const std::string s = line();
      char* end = nullptr;
      const double v = std::strtod(s.c_str(), &end);
      if (s.empty() || *end) error("bad FLOAT argument '" + s + "'");
      PyObj* o = make(PyKind::floating);
      o->f = v;
      push(o);
      return true;
    }
    case 'X': push(make_text(PyKind::string, raw(uint_le(4)))); return true;     // BINUNICODE
    case 0x8c: push(make_text(PyKind::string, raw(uint_le(1)))); return true;   // SHORT_BINUNICODE
    case 0x8d: push(make_text(PyKind::string, raw(uint_le(8)))); return true;   // BINUNICODE8
    case 'T': push(make_text(PyKind::bytes, raw(uint_le(4)))); return true;     // BINSTRING (py2 str)
    case 'U': push(make_text(PyKind::bytes, raw(uint_le(1)))); return true;     // SHORT_BINSTRING
    case 'B': push(make_text(PyKind::bytes, raw(uint_le(4)))); return true;     // BINBYTES
    case 'C': push(make_text(PyKind::bytes, raw(uint_le(1)))); return true;     // SHORT_BINBYTES
    case 0x8e: push(make_text(PyKind::bytes, raw(uint_le(8)))); return true;    // BINBYTES8
    case 0x96: push(make_text(PyKind::bytes, raw(uint_le(8)))); return true;    // BYTEARRAY8
    case 0x98: top(); return true;  // READONLY_BUFFER: in-band data is already a plain copy
    default: return false;
  }
}

bool PickleParser::container_op(uint8_t op) {
  switch (op) {
    case ')': push(make(PyKind::tuple)); return true;  // EMPTY_TUPLE
    case 0x85: { PyObj* a = pop(); push(make_tuple({a})); return true; }                        // TUPLE1
    case 0x86: { PyObj* b = pop(); PyObj* a = pop(); push(make_tuple({a, b})); return true; }  // TUPLE2
    case 0x87: {                                                                                // TUPLE3
      PyObj* c = pop(); PyObj* b = pop(); PyObj* a = pop();
      push(make_tuple({a, b, c}));
      return true;
    }
    case 't': push(make_tuple(pop_mark())); return true;  // TUPLE
    case ']': push(make(PyKind::list)); return true;      // EMPTY_LIST
    case 'l': {                                           // LIST
      PyObj* o = make(PyKind::list);
      auto items = pop_mark();
      o->items.assign(items.begin(), items.end());
      push(o);
      return true;
    }
    case 'a': {  // APPEND
      PyObj* v = pop();
      PyObj* l = top();
      if (l->kind != PyKind::list) error(std::string("APPEND to a ") + py_kind_name(l->kind));
      l->items.push_back(v);
      return true;
    }
    case 'e': {  // APPENDS
      auto items = pop_mark();
      PyObj* l = top();
      if (l->kind != PyKind::list) error(std::string("APPENDS to a ") + py_kind_name(l->kind));
      l->items.insert(l->items.end(), items.begin(), items.end());
      return true;
    }
    case '}': push(make(PyKind::dict)); return true;  // EMPTY_DICT
    case 'd': {                                       // DICT
      PyObj* d = make(PyKind::dict);
      set_items(d, pop_mark());
      push(d);
      return true;
    }
    case 's': {  // SETITEM
      PyObj* v = pop();
      PyObj* k = pop();
      set_items(top(), {k, v});
      return true;
    }
    case 'u': {  // SETITEMS
      auto kv = pop_mark();
      set_items(top(), kv);
      return true;
    }
    case 0x8f: push(make(PyKind::set)); return true;  // EMPTY_SET
    case 0x90: {                                      // ADDITEMS
      auto items = pop_mark();
      PyObj* s = top();
      if (s->kind != PyKind::set || frozen_.count(s)) error("ADDITEMS to something other than a set");
      s->items.insert(s->items.end(), items.begin(), items.end());
      return true;
    }
    case 0x91: {  // FROZENSET
      PyObj* s = make(PyKind::set);
      auto items = pop_mark();
      s->items.assign(items.begin(), items.end());
      frozen_[s] = true;
      push(s);
      return true;
    }
    default: return false;
  }
}

bool PickleParser::memo_op(uint8_t op) {
  switch (op) {
    case 'p': {  // PUT (text)
      const std::string s = line();
      char* end = nullptr;
      const unsigned long long idx = std::strtoull(s.c_str(), &end, 10);
      if (s.empty() || *end) error("bad PUT argument");
      memo_put(idx, top());
      return true;
    }
    case 'g': {  // GET (text)
      const std::string s = line();
      char* end = nullptr;
      const unsigned long long idx = std::strtoull(s.c_str(), &end, 10);
      if (s.empty() || *end) error("bad GET argument");
      push(memo_get(idx));
      return true;
    }
    case 'q': memo_put(uint_le(1), top()); return true;     // BINPUT
    case 'r': memo_put(uint_le(4), top()); return true;     // LONG_BINPUT
    case 0x94: memo_put(memo_.size(), top()); return true;  // MEMOIZE
    case 'h': push(memo_get(uint_le(1))); return true;      // BINGET
    case 'j': push(memo_get(uint_le(4))); return true;      // LONG_BINGET
    default: return false;
  }
}

bool PickleParser::object_op(uint8_t op) {
  switch (op) {
    case 'c': {  // GLOBAL "module\nname\n"
      const std::string module = line();
      const std::string name = line();
      resolve_global(module, name);
      return true;
    }
    case 0x93: {  // STACK_GLOBAL
      PyObj* name = pop();
      PyObj* module = pop();
      if (module->kind != PyKind::string || name->kind != PyKind::string) error("STACK_GLOBAL on non-strings");
      resolve_global(module->str, name->str);
      return true;
    }
    case 'R': reduce(); return true;
    case 'b': build(); return true;
    default: return false;
  }
}

void PickleParser::refuse_op(uint8_t op) {
  switch (op) {
    case 0x97: error("out-of-band buffer (NEXT_BUFFER) is not supported");
    case 0x81:  // NEWOBJ
    case 0x92:  // NEWOBJ_EX
      error("object construction (NEWOBJ) is not allowed");
    case 'i': case 'o':
      error("object construction (INST/OBJ) is not allowed");
    case 'P': case 'Q':
      error("persistent ids are not supported (torch tensors? save numpy arrays instead)");
    case 0x82: case 0x83: case 0x84:
      error("extension registry codes are not supported");
    case 'S': case 'V':
      error("protocol-0 text strings are not supported (re-save with protocol 2 or higher)");
    default: {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02x", op);
      error(std::string("unknown opcode ") + hex + " (corrupt file?)");
    }
  }
}

Pickle Pickle::parse(const uint8_t* data, size_t size, const std::string& where) {
  PickleParser p(data, size, where);
  return p.run();
}

Pickle Pickle::read(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open");
  f.seekg(0, std::ios::end);
  const std::streamoff len = f.tellg();
  if (len < 0) fail(path, "cannot read");
  if (len > (std::streamoff(1) << 32)) fail(path, "pickle larger than 4 GiB");
  f.seekg(0);
  std::vector<uint8_t> buf(static_cast<size_t>(len));
  if (len > 0 && !f.read(reinterpret_cast<char*>(buf.data()), len)) fail(path, "cannot read");
  return parse(buf.data(), buf.size(), path);
}

}  // namespace haha
