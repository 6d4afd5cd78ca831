// The safe pickle reader: every value kind numpy/Python write with protocols 2-5 (fixtures
// written once by scripts/make_pickle_fixtures.py), refusal of anything executable, and
// robustness: every truncation and thousands of byte mutations of a real pickle either
// parse or throw haha::Error naming the file; nothing crashes or allocates unboundedly.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/pickle.h"
#include "io/pickle_write.h"
#include "support/expect_error.h"

namespace haha {
using haha::test::expect_error;
namespace {

std::string data_dir() {
  return (std::filesystem::path(__FILE__).parent_path().parent_path() / "fixtures" / "pickle").string();
}

std::vector<uint8_t> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

std::vector<double> nums(const Pickle& p, const std::string& key, std::vector<int64_t> shape) {
  PyNumbers n = p.numbers(key);
  EXPECT_EQ(n.shape, shape) << key;
  return n.values;
}

class ValuesTest : public ::testing::TestWithParam<int> {};

TEST_P(ValuesTest, EveryValueKindMatchesWhatPythonWrote) {
  const std::string path = data_dir() + "/values_p" + std::to_string(GetParam()) + ".pkl";
  const Pickle p = Pickle::read(path);
  ASSERT_EQ(p.root().kind, PyKind::dict);
  EXPECT_EQ(p.where(), path);

  EXPECT_EQ(p.find("none")->kind, PyKind::none);
  EXPECT_EQ(p.find("true")->kind, PyKind::boolean);
  EXPECT_TRUE(p.find("true")->b);
  EXPECT_FALSE(p.find("false")->b);
  EXPECT_EQ(p.find("missing"), nullptr);

  const std::vector<int64_t> ints = {0, 1, -1, 255, 256, 65535, 65536, -(int64_t(1) << 31), int64_t(1) << 31,
                                     int64_t(1) << 40, INT64_MIN, INT64_MAX};
  const PyObj* il = p.find("ints");
  ASSERT_EQ(il->kind, PyKind::list);
  ASSERT_EQ(il->items.size(), ints.size());
  for (size_t k = 0; k < ints.size(); ++k) {
    EXPECT_EQ(il->items[k]->kind, PyKind::integer);
    EXPECT_EQ(il->items[k]->i, ints[k]) << k;
  }
  EXPECT_EQ(p.find("float")->f, 1.5);
  EXPECT_EQ(p.find("neg_float")->f, -2.25e-3);
  EXPECT_EQ(p.find("text")->kind, PyKind::string);
  EXPECT_EQ(p.find("text")->str, "h\xc3\xa9llo");
  EXPECT_EQ(p.find("raw")->kind, PyKind::bytes);
  EXPECT_EQ(p.find("raw")->str, std::string("\x00\x01\xff", 3));

  const PyObj* t = p.find("tuple");
  ASSERT_EQ(t->kind, PyKind::tuple);
  ASSERT_EQ(t->items.size(), 3u);
  EXPECT_EQ(t->items[0]->i, 1);
  EXPECT_EQ(t->items[1]->f, 2.5);
  EXPECT_EQ(t->items[2]->str, "x");

  EXPECT_EQ(nums(p, "nested", {2, 2}), (std::vector<double>{1, 2, 3, 4}));
  // Shared references resolve to the very same object.
  EXPECT_EQ(p.find("shared_a"), p.find("shared_b"));
  EXPECT_EQ(nums(p, "shared_a", {3}), (std::vector<double>{1, 2, 3}));
  const PyObj* od = p.find("ordered");
  ASSERT_EQ(od->kind, PyKind::dict);
  EXPECT_EQ(od->keys(), (std::vector<std::string>{"b", "a"}));
  EXPECT_EQ(od->get("a")->i, 1);

  EXPECT_EQ(nums(p, "f32_scalar", {}), (std::vector<double>{0.25}));
  EXPECT_EQ(p.find("f32_scalar")->array.dtype, DType::f32);
  EXPECT_EQ(nums(p, "i64_scalar", {}), (std::vector<double>{-7}));
  EXPECT_EQ(nums(p, "f64", {2, 3}), (std::vector<double>{0, 0.25, 0.5, 0.75, 1.0, 1.25}));
  EXPECT_EQ(p.find("f64")->array.dtype, DType::f64);
  {
    std::vector<double> f32 = nums(p, "f32", {2, 3, 4});
    for (int k = 0; k < 24; ++k) EXPECT_EQ(f32[size_t(k)], k - 3.5);
  }
  // Fortran-ordered storage comes back in C order: arange(6).reshape(3, 2).
  EXPECT_EQ(nums(p, "fortran", {3, 2}), (std::vector<double>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(nums(p, "big_endian", {4}), (std::vector<double>{0, 1.5, 3.0, 4.5}));
  EXPECT_EQ(nums(p, "i64", {3}), (std::vector<double>{-5, 0, double(int64_t(1) << 40)}));
  EXPECT_EQ(nums(p, "i32", {2, 2}), (std::vector<double>{-1, 2, 3, -4}));
  EXPECT_EQ(nums(p, "u32", {2}), (std::vector<double>{0, 4000000000.0}));
  EXPECT_EQ(nums(p, "u8", {3}), (std::vector<double>{0, 7, 255}));
  EXPECT_EQ(nums(p, "i16", {2}), (std::vector<double>{-300, 300}));
  EXPECT_EQ(nums(p, "bool", {3}), (std::vector<double>{1, 0, 1}));
  EXPECT_EQ(nums(p, "f16", {3}), (std::vector<double>{0.5, -2.0, 65504.0}));
  EXPECT_EQ(nums(p, "zero_d", {}), (std::vector<double>{3.0}));
  EXPECT_TRUE(nums(p, "empty", {0, 3}).empty());

  // Non-numeric arrays load (shape known) but asking for numbers names file and key.
  EXPECT_EQ(p.find("unicode_array")->array.dtype, DType::unsupported);
  EXPECT_EQ(p.find("unicode_array")->array.shape, (std::vector<int64_t>{2}));
  expect_error([&] { p.numbers("unicode_array"); }, {path, "unicode_array", "U"});
  expect_error([&] { p.numbers("object_array"); }, {path, "object_array"});
  expect_error([&] { p.numbers("text"); }, {path, "text", "str"});
  expect_error([&] { p.numbers("missing"); }, {path, "missing"});

  // Non-string keys are kept, just not listed by keys().
  bool int_key = false;
  for (const auto& [k, v] : p.root().entries)
    if (k->kind == PyKind::integer && k->i == 7) int_key = v->str == "int key";
  EXPECT_TRUE(int_key);
}

INSTANTIATE_TEST_SUITE_P(Protocols, ValuesTest, ::testing::Values(2, 3, 4, 5));

TEST(Pickle, SmplxFitWithLeadingAxisInDoublePrecision) {
  const Pickle p = Pickle::read(data_dir() + "/smplx_f64_lead1_p2.pkl");
  const std::vector<double> body = nums(p, "body_pose", {1, 63});
  for (int k = 0; k < 63; ++k) EXPECT_DOUBLE_EQ(body[size_t(k)], 3 + 0.01 * 2 + 0.001 * k);
  EXPECT_EQ(p.find("body_pose")->array.dtype, DType::f64);
}

TEST(PickleWrite, FloatArrayDictReadsBackLikeTheXHumansFixture) {
  // The X-Humans fixture (written by Python's pickle of numpy arrays) and our writer's
  // pickle of the same dict read back to the same keys, shapes and values.
  const Pickle py = Pickle::read(data_dir() + "/xhumans/mesh-f00001_smplx.pkl");
  std::vector<PickleArray> arrays;
  for (const std::string& key : py.root().keys()) {
    const PyNumbers n = py.numbers(key);
    PickleArray a;
    a.key = key;
    for (double v : n.values) a.values.push_back(float(v));
    a.shape = n.shape;
    arrays.push_back(a);
  }
  ASSERT_GE(arrays.size(), 5u);
  arrays.push_back({"long", std::vector<float>(300, 0.25f), {3, 100}});  // BINBYTES, 2-D
  const std::vector<uint8_t> bytes = pickle_float_arrays(arrays);
  const Pickle ours = Pickle::parse(bytes.data(), bytes.size(), "ours");
  EXPECT_EQ(ours.root().keys().size(), arrays.size());
  for (const PickleArray& a : arrays) {
    const PyNumbers n = ours.numbers(a.key);
    EXPECT_EQ(n.shape, a.shape) << a.key;
    ASSERT_EQ(n.values.size(), a.values.size()) << a.key;
    for (size_t i = 0; i < a.values.size(); ++i) EXPECT_EQ(float(n.values[i]), a.values[i]) << a.key;
    EXPECT_EQ(ours.find(a.key)->numpy_dtype, "<f4") << a.key;
  }
  expect_error([] { pickle_float_arrays({{"x", {1, 2, 3}, {2, 2}}}); }, {"x", "shape"});
}

TEST(Pickle, Numpy2ModuleSpelling) {
  const Pickle p = Pickle::read(data_dir() + "/numpy2_p2.pkl");
  EXPECT_EQ(nums(p, "a", {3}), (std::vector<double>{0, 1, 2}));
  EXPECT_EQ(nums(p, "s", {}), (std::vector<double>{2.5}));
}

TEST(Pickle, RefusesArbitraryGlobalsNamingFileAndGlobal) {
  const std::string path = data_dir() + "/evil_global.pkl";
  expect_error([&] { Pickle::read(path); }, {path, "system", "not allowed"});
}

// Hand-made pickles for the cases numpy never writes.
struct Bytes {
  std::vector<uint8_t> b;
  Bytes& op(uint8_t c) { b.push_back(c); return *this; }
  Bytes& raw(const std::string& s) { b.insert(b.end(), s.begin(), s.end()); return *this; }
  Bytes& u32(uint32_t v) { for (int k = 0; k < 4; ++k) b.push_back(uint8_t(v >> (8 * k))); return *this; }
  Bytes& u64(uint64_t v) { for (int k = 0; k < 8; ++k) b.push_back(uint8_t(v >> (8 * k))); return *this; }
  Bytes& str(const std::string& s) { op(0x8c).op(uint8_t(s.size())); return raw(s); }  // SHORT_BINUNICODE
  Pickle parse() const { return Pickle::parse(b.data(), b.size(), "hand.pkl"); }
};

TEST(Pickle, RefusesTorchPersistentIdsAndObjectConstruction) {
  expect_error([] { Bytes().op(0x80).op(2).op('c').raw("torch._utils\n_rebuild_tensor_v2\n").parse(); },
               {"hand.pkl", "torch._utils._rebuild_tensor_v2", "torch"});
  expect_error([] { Bytes().op(0x80).op(2).op('N').op('Q').op('.').parse(); }, {"hand.pkl", "persistent"});
  expect_error([] { Bytes().op(0x80).op(4).str("builtins").str("eval").op(0x93).parse(); },
               {"hand.pkl", "builtins.eval"});
  // An allowed global is still never called with NEWOBJ.
  expect_error([] { Bytes().op(0x80).op(4).str("numpy").str("ndarray").op(0x93).op(')').op(0x81).op('.').parse(); },
               {"hand.pkl", "NEWOBJ"});
  // BUILD on a plain dict would set attributes on an object in Python: refused.
  expect_error([] { Bytes().op(0x80).op(2).op('}').op('}').op('b').op('.').parse(); }, {"hand.pkl", "BUILD"});
}

TEST(Pickle, CorruptStructuresAreErrorsNotCrashes) {
  expect_error([] { Bytes().parse(); }, {"hand.pkl", "truncated"});
  expect_error([] { Bytes().op(0x80).op(9).parse(); }, {"hand.pkl", "protocol 9"});
  expect_error([] { Bytes().op(0x80).op(2).op('.').parse(); }, {"hand.pkl", "STOP"});      // empty stack
  expect_error([] { Bytes().op(0x80).op(2).op('N').op('N').op('.').parse(); }, {"hand.pkl", "STOP"});
  expect_error([] { Bytes().op(0x80).op(2).op('h').op(3).op('.').parse(); }, {"hand.pkl", "memo"});
  expect_error([] { Bytes().op(0x80).op(2).op('0').parse(); }, {"hand.pkl", "underflow"});
  expect_error([] { Bytes().op(0x80).op(2).op('(').op('a').parse(); }, {"hand.pkl", "underflow"});
  expect_error([] { Bytes().op(0x80).op(2).op('t').parse(); }, {"hand.pkl", "MARK"});
  expect_error([] { Bytes().op(0x80).op(2).op(0xff).parse(); }, {"hand.pkl", "0xff"});
  // Lengths far beyond the input never allocate.
  expect_error([] { Bytes().op(0x80).op(4).op(0x8d).u64(uint64_t(1) << 62).parse(); }, {"hand.pkl", "truncated"});
  expect_error([] { Bytes().op(0x80).op(4).op(0x8e).u64(~uint64_t(0)).parse(); }, {"hand.pkl", "truncated"});
  expect_error([] { Bytes().op(0x80).op(2).op(0x8b).u32(0xffffffffu).parse(); }, {"hand.pkl", "64 bits"});
  // Array data shorter than the shape: (2,) float32 with 4 bytes.
  Bytes arr;
  arr.op(0x80).op(4).str("numpy.core.numeric").str("_frombuffer").op(0x93).op('(')
      .op('C').op(4).raw(std::string(4, '\0'))
      .str("numpy").str("dtype").op(0x93).str("f4").op(0x89).op(0x88).op(0x87).op('R')
      .op('K').op(2).op(0x85).str("C").op('t').op('R').op('.');
  expect_error([&] { arr.parse(); }, {"hand.pkl", "4 bytes", "needs 8"});
}

TEST(Pickle, MemoReferencesCannotMultiplyMemory) {
  // One 4 KiB buffer turned into thousands of arrays through memo references.
  Bytes p;
  p.op(0x80).op(4);
  p.str("numpy.core.numeric").str("_frombuffer").op(0x93).op('q').op(0);
  p.op('B').u32(4096).raw(std::string(4096, '\1')).op('q').op(1);
  p.str("numpy").str("dtype").op(0x93).str("u1").op(0x89).op(0x88).op(0x87).op('R').op('q').op(2);
  p.op('M').op(0x00).op(0x10).op(0x85).op('q').op(3);  // (4096,)
  p.str("C").op('q').op(4);
  p.op('0').op('0').op('0').op('0').op('0');  // clear the stack, keep the memo
  p.op(']');
  for (int k = 0; k < 5000; ++k) p.op('h').op(0).op('(').op('h').op(1).op('h').op(2).op('h').op(3).op('h').op(4).op('t').op('R').op('a');
  p.op('.');
  expect_error([&] { p.parse(); }, {"hand.pkl", "exceeds"});

  // A list DAG with 2^60 paths built from 60 memo entries: walking it is bounded.
  Bytes d;
  d.op(0x80).op(2).op('K').op(1).op('q').op(0).op('0');
  for (int k = 0; k < 60; ++k) d.op('h').op(uint8_t(k)).op('h').op(uint8_t(k)).op(0x86).op('q').op(uint8_t(k + 1)).op('0');
  d.op('h').op(60).op('.');
  const Pickle dag = d.parse();
  expect_error([&] { py_numbers(dag.root(), "hand.pkl: dag"); }, {"hand.pkl: dag", "too"});
}

TEST(Pickle, RaggedListsAreNotArrays) {
  // [[1, 2], [3]]
  Bytes b;
  b.op(0x80).op(2).op(']').op('(').op(']').op('(').op('K').op(1).op('K').op(2).op('e').op(']').op('K').op(3).op('a').op('e').op('.');
  const Pickle p = b.parse();
  expect_error([&] { py_numbers(p.root(), "hand.pkl: x"); }, {"hand.pkl: x", "ragged"});
}

TEST(Pickle, EveryTruncationOfARealPickleIsAnError) {
  for (int proto : {2, 5}) {
    const std::vector<uint8_t> full = file_bytes(data_dir() + "/values_p" + std::to_string(proto) + ".pkl");
    ASSERT_GT(full.size(), 100u);
    for (size_t n = 0; n < full.size(); ++n) {
      try {
        Pickle::parse(full.data(), n, "cut.pkl");
        ADD_FAILURE() << "prefix of " << n << " bytes parsed";
      } catch (const Error& e) {
        ASSERT_NE(std::string(e.what()).find("cut.pkl"), std::string::npos) << e.what();
      }
    }
  }
}

TEST(Pickle, RandomByteMutationsParseOrThrowNamedErrors) {
  const std::vector<uint8_t> full = file_bytes(data_dir() + "/values_p4.pkl");
  std::mt19937 rng(1234);
  int errors = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    std::vector<uint8_t> m = full;
    const int flips = 1 + int(rng() % 3);
    for (int k = 0; k < flips; ++k) m[rng() % m.size()] = uint8_t(rng());
    try {
      const Pickle p = Pickle::parse(m.data(), m.size(), "mut.pkl");
      // Whatever parsed must be walkable without crashing.
      if (p.root().kind == PyKind::dict)
        for (const auto& key : p.root().keys()) try { p.numbers(key); } catch (const Error&) {}
    } catch (const Error& e) {
      ++errors;
      ASSERT_NE(std::string(e.what()).find("mut.pkl"), std::string::npos) << e.what();
    }
  }
  EXPECT_GT(errors, 1000);  // mutations mostly break the structure; they must be reported
}

}  // namespace
}  // namespace haha
