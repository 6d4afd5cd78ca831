#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
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

// A header whose shape claims far more than the data holds, or dimensions whose product
// overflows, is refused before anything is allocated for it.
std::vector<uint8_t> npy_with_shape(const std::string& shape, size_t data_bytes) {
  std::string h = "{'descr': '<f4', 'fortran_order': False, 'shape': " + shape + ", }";
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::vector<uint8_t> out = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, uint8_t(h.size() & 0xff), uint8_t(h.size() >> 8)};
  out.insert(out.end(), h.begin(), h.end());
  out.resize(out.size() + data_bytes, 0);
  return out;
}

TEST(Npy, HostileShapesAreRefusedBeforeAllocating) {
  for (const std::string shape : {"(2000000000, 1000000)", "(1099511627776, 1099511627776, 1099511627776)",
                                  "(4294967296, 4294967296)"}) {
    const std::vector<uint8_t> b = npy_with_shape(shape, 1024);
    expect_error([&] { parse_npy(b.data(), b.size(), "h.npz: key"); }, "h.npz: key", "truncated");
  }
  const std::vector<uint8_t> big = npy_with_shape("(123456789012345678901234567890,)", 16);
  expect_error([&] { parse_npy(big.data(), big.size(), "h.npz: key"); }, "h.npz: key", "dimension too large");
  const std::vector<uint8_t> ok = npy_with_shape("(2, 2)", 16);
  EXPECT_EQ(parse_npy(ok.data(), ok.size(), "ok").as_float().size(), 4u);
  const std::vector<uint8_t> empty = npy_with_shape("(0, 1099511627776)", 0);
  EXPECT_EQ(parse_npy(empty.data(), empty.size(), "empty").size(), 0);
}

TEST(Npy, ZipMemberClaimingMoreThanItsBytesCanHoldIsRefused) {
  Npz z;
  z.set("a", NpyArray::from(std::vector<float>(64, 1.0f), {64}));
  const std::string p = tmp("claim.npz");
  z.write(p);
  std::string bytes;
  {
    std::ifstream f(p, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  // Central directory entry (signature PK\1\2): uncompressed size at offset 24 -> 3 GB.
  const size_t cd = bytes.find(std::string("PK\x01\x02", 4));
  ASSERT_NE(cd, std::string::npos);
  const uint32_t claim = 3000000000u;
  std::memcpy(&bytes[cd + 24], &claim, 4);
  std::ofstream(p, std::ios::binary) << bytes;
  expect_error([&] { Npz::read(p); }, p, "claims 3000000000 bytes");
  std::filesystem::remove(p);
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
