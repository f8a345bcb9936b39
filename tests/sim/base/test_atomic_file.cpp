// The one atomic writer: all or nothing at the destination, normal permissions, clear errors.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "sim/base/atomic_file.h"
#include "sim/base/error.h"

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

std::size_t filesIn(const fs::path& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

}  // namespace

TEST(AtomicFile, CommitPlacesTheWholeFileAndNothingElse) {
  const fs::path dir = fs::temp_directory_path() / ("handson_atomic_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path out = dir / "out.bin";
  std::ofstream(out) << "old contents";
  {
    handson::AtomicFile f(out.string(), "the test file");
    f.write("abc", 3);
    std::ofstream(f.tempPath(), std::ios::app) << "def";  // a library writing by name
    EXPECT_EQ(slurp(out), "old contents") << "the destination is untouched until commit";
    f.commit();
  }
  EXPECT_EQ(slurp(out), "abcdef");
  EXPECT_EQ(filesIn(dir), 1u) << "no temporary file left";
  const mode_t mask = ::umask(0);
  ::umask(mask);
  struct stat st{};
  ASSERT_EQ(::stat(out.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0666 & ~mask) << "a new file's permissions, not mkstemp's 0600";
  // Without commit (an error on the way): the destination keeps its old contents, no temporary file.
  {
    handson::AtomicFile f(out.string());
    f.write("partial", 7);
  }
  EXPECT_EQ(slurp(out), "abcdef");
  EXPECT_EQ(filesIn(dir), 1u);
  // A directory that does not exist: a clear error naming the file.
  try {
    handson::AtomicFile f((dir / "no" / "such.bin").string(), "the test file");
    FAIL();
  } catch (const handson::Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot write the test file"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_THROW(handson::AtomicFile(""), handson::Error);
  fs::remove_all(dir);
}
