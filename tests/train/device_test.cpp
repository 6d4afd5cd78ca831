// --device parsing (train/device.h): the names, and a clear error where no GPU can be used.
#include <gtest/gtest.h>

#include <string>

#include "core/error.h"
#include "train/device.h"

namespace haha {
namespace {

std::string error_of(const std::string& name) {
  try {
    parse_device(name);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Device, NamesAndErrors) {
  EXPECT_EQ(parse_device("cpu"), Device::cpu);
  EXPECT_STREQ(device_name(Device::cpu), "cpu");
  EXPECT_STREQ(device_name(Device::cuda), "cuda");
  const std::string unknown = error_of("gpu");
  EXPECT_NE(unknown.find("--device"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("unknown device 'gpu'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("cpu, cuda or auto"), std::string::npos) << unknown;
  // cuda is accepted exactly where a backend is built and a device answers; elsewhere the
  // error says which of the two is missing.
  const std::string cuda = error_of("cuda");
  if (!cuda_backend_built()) {
    EXPECT_NE(cuda.find("no CUDA backend"), std::string::npos) << cuda;
    EXPECT_TRUE(gpu_description().empty());
  } else if (!cuda.empty()) {
    EXPECT_NE(cuda.find("cuda: no usable GPU: "), std::string::npos) << cuda;
    EXPECT_EQ(parse_device("auto"), Device::cpu);
  } else {
    EXPECT_EQ(parse_device("cuda"), Device::cuda);
    EXPECT_EQ(parse_device("auto"), Device::cuda);
    EXPECT_FALSE(gpu_description().empty());
  }
  if (!cuda_backend_built()) {
    EXPECT_EQ(parse_device("auto"), Device::cpu);
  }
}

}  // namespace
}  // namespace haha
