#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <unistd.h>

#include "core/error.h"
#include "io/npy.h"
#include "support/expect_error.h"

using namespace haha;
using haha::test::expect_error;

namespace {
std::string tmp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("haha_npy_" + std::to_string(::getpid()) + "_" + name)).string();
}
}  // namespace

TEST(Npy, RoundTripAllDtypes) {
  Npz z;
  z.set("f", NpyArray::from(std::vector<float>{1.5f, -2.f, 3.f, 4.f, 5.f, 6.f}, {2, 3}));
  z.set("d", NpyArray::from(std::vector<double>{1e-300, 2.0}, {2}));
  z.set("i", NpyArray::from(std::vector<int32_t>{-7, 8, 9}, {3, 1}));
  z.set("l", NpyArray::from(std::vector<int64_t>{1LL << 40}, {}));
  const std::string p = tmp("rt.npz");
  z.write(p);
  Npz r = Npz::read(p);
  EXPECT_EQ(r.get("f", {2, 3}).as_float(), (std::vector<float>{1.5f, -2.f, 3.f, 4.f, 5.f, 6.f}));
  EXPECT_EQ(r.get("d").as_double()[0], 1e-300);
  EXPECT_EQ(r.get("i").shape, (std::vector<int64_t>{3, 1}));
  EXPECT_EQ(r.get("i").as_int32(), (std::vector<int32_t>{-7, 8, 9}));
  EXPECT_TRUE(r.get("l").shape.empty());
  EXPECT_EQ(r.get("l").as_double()[0], double(1LL << 40));
  expect_error([&] { (void)r.get("l").as_int32(); }, "out of int32 range");
  std::remove(p.c_str());
}

TEST(Npy, ParsesFortranOrderAndUint32) {
  // A hand-built v1.0 header, Fortran order 2x3 uint32 with values laid out column-major.
  std::string h = "{'descr': '<u4', 'fortran_order': True, 'shape': (2, 3), }";
  h.append(64 - (10 + h.size() + 1) % 64, ' ');
  h += '\n';
  std::vector<uint8_t> buf = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, uint8_t(h.size()), 0};
  buf.insert(buf.end(), h.begin(), h.end());
  const uint32_t col_major[6] = {0, 3, 1, 4, 2, 5};  // C-order values 0..5
  const uint8_t* p = reinterpret_cast<const uint8_t*>(col_major);
  buf.insert(buf.end(), p, p + sizeof(col_major));
  NpyArray a = parse_npy(buf.data(), buf.size(), "mem");
  EXPECT_EQ(a.as_int32(), (std::vector<int32_t>{0, 1, 2, 3, 4, 5}));
}

TEST(Npy, BadInputNamesFileAndKey) {
  const std::string p = tmp("bad.npz");
  Npz z;
  z.set("weights", NpyArray::from(std::vector<float>(6, 0.f), {3, 2}));
  z.write(p);
  Npz r = Npz::read(p);
  expect_error([&] { r.get("v_template"); }, p, "v_template: missing");
  expect_error([&] { r.get("weights", {3, 55}); }, "weights", "wrong shape (3, 2), expected (3, 55)");
  // Not a zip at all.
  const std::string q = tmp("junk.npz");
  std::ofstream(q) << "definitely not a zip";
  expect_error([&] { Npz::read(q); }, q, "cannot open as .npz");
  // Truncated npy payload.
  NpyArray a = NpyArray::from(std::vector<float>(100, 1.f), {100});
  auto bytes = serialize_npy(a);
  bytes.resize(bytes.size() - 10);
  expect_error([&] { parse_npy(bytes.data(), bytes.size(), "x.npz: key"); }, "x.npz: key", "truncated");
  std::remove(p.c_str());
  std::remove(q.c_str());
}

TEST(Npy, UnsupportedDtypeIsListedButNotDecoded) {
  std::string h = "{'descr': '|O', 'fortran_order': False, 'shape': (), }";
  h.append(64 - (10 + h.size() + 1) % 64, ' ');
  h += '\n';
  std::vector<uint8_t> buf = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, uint8_t(h.size()), 0};
  buf.insert(buf.end(), h.begin(), h.end());
  NpyArray a = parse_npy(buf.data(), buf.size(), "mem");
  EXPECT_EQ(a.dtype, DType::unsupported);
  expect_error([&] { (void)a.as_float(); }, "unsupported dtype");
}
