// Atomic file writes (libhaha/core/atomic_file.h): a finished write replaces the file whole,
// a failed one leaves the old file and no working file, text files round-trip bytes
// (empty, NUL, no trailing newline), errors name the path, directories are created with
// their parents.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "core/atomic_file.h"
#include "core/error.h"
#include "support/expect_error.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using test::expect_error;

class AtomicFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("haha_atomic_file_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  // Entries of the test directory: a leftover working file would show here.
  int entries() const { return int(std::distance(fs::directory_iterator(dir_), fs::directory_iterator())); }
  fs::path dir_;
};

TEST_F(AtomicFile, TextRoundTripsExactBytes) {
  for (const std::string& text : {std::string(), std::string("no newline"), std::string("a\0b\r\n\xff", 6),
                                  std::string(100000, 'x')}) {
    write_text_file(path("t.txt"), text);
    EXPECT_EQ(read_text_file(path("t.txt")), text);
    EXPECT_EQ(fs::file_size(path("t.txt")), text.size());
  }
  EXPECT_EQ(entries(), 1);
}

TEST_F(AtomicFile, FinishedWriteReplacesAndTheWriterSeesAWorkingPath) {
  write_text_file(path("f"), "old contents, longer than the new");
  std::string tmp;
  write_atomically(path("f"), [&](const std::string& t) {
    tmp = t;
    EXPECT_NE(t, path("f"));
    EXPECT_EQ(fs::path(t).parent_path(), dir_);  // same directory: the rename stays on one file system
    EXPECT_EQ(read_text_file(path("f")), "old contents, longer than the new");  // untouched until done
    std::ofstream(t) << "new";
  });
  EXPECT_EQ(read_text_file(path("f")), "new");
  EXPECT_FALSE(fs::exists(tmp));
  EXPECT_EQ(entries(), 1);
  // Two writes never share a working path.
  std::string tmp2;
  write_atomically(path("f"), [&](const std::string& t) {
    tmp2 = t;
    std::ofstream(t) << "again";
  });
  EXPECT_NE(tmp, tmp2);
}

TEST_F(AtomicFile, FailedWriteLeavesTheOldFileAndNoWorkingFile) {
  write_text_file(path("f"), "old");
  EXPECT_THROW(write_atomically(path("f"),
                                [](const std::string& t) {
                                  std::ofstream(t) << "half";
                                  throw std::runtime_error("writer failed");
                                }),
               std::runtime_error);
  EXPECT_EQ(read_text_file(path("f")), "old");
  EXPECT_EQ(entries(), 1);
  // A failure before the first byte: nothing appears at all.
  EXPECT_THROW(write_atomically(path("g"), [](const std::string&) { throw Error("nothing written"); }), Error);
  EXPECT_FALSE(fs::exists(path("g")));
  EXPECT_EQ(entries(), 1);
}

TEST_F(AtomicFile, FileThatCannotBeMovedIntoPlaceIsAnErrorNamingItAndLeavesNothing) {
  // A non-empty directory where the file should go: the rename fails.
  fs::create_directories(path("d/inner"));
  expect_error([&] { write_text_file(path("d"), "x"); }, path("d"));
  EXPECT_TRUE(fs::is_directory(path("d/inner")));
  EXPECT_EQ(entries(), 1);
  // A missing parent directory: the working file cannot be written.
  expect_error([&] { write_text_file(path("missing/f"), "x"); }, path("missing/f"));
  EXPECT_FALSE(fs::exists(path("missing")));
}

TEST_F(AtomicFile, ReadingAMissingFileNamesIt) {
  expect_error([&] { read_text_file(path("absent.txt")); }, path("absent.txt"));
}

TEST_F(AtomicFile, EnsureDirectoryCreatesParentsIsIdempotentAndNamesAFileInTheWay) {
  ensure_directory(path("a/b/c"));
  EXPECT_TRUE(fs::is_directory(path("a/b/c")));
  ensure_directory(path("a/b/c"));  // already there: fine
  ensure_directory(path("a/b"));
  write_text_file(path("file"), "x");
  expect_error([&] { ensure_directory(path("file/sub")); }, path("file/sub"));
}

}  // namespace
}  // namespace haha
