#include "sim/base/binary_io.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <sstream>

#include "sim/base/error.h"

namespace handson {
namespace {

struct Stream {
  std::stringstream bytes;
  bin::Writer writer() { return {bytes}; }
  bin::Reader reader() {
    const std::string s = bytes.str();
    return {bytes, s.size()};
  }
};

TEST(BinaryIo, ValuesVectorsStringsAndMatricesRoundTrip) {
  // The matrices' bytes are their scalars column after column, whatever their compile-time shape:
  // a file written from one shape reads into another of the same size.
  Stream s;
  Eigen::Matrix<double, Eigen::Dynamic, 3> tall(4, 3);
  tall.setRandom();
  const Eigen::Matrix3d fixed = Eigen::Matrix3d::Random();
  auto w = s.writer();
  w.pod(std::int32_t(-7));
  w.podVector(std::vector<Eigen::Vector3f>{{1, 2, 3}, {4, 5, 6}});
  w.string("kidney");
  w.matrix(tall);
  w.matrix(fixed.transpose());  // an expression: written as its plain matrix
  w.matrix(Eigen::MatrixXd(0, 5));
  auto r = s.reader();
  EXPECT_EQ(r.pod<std::int32_t>(), -7);
  const auto v = r.podVector<Eigen::Vector3f>();
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[1], Eigen::Vector3f(4, 5, 6));
  EXPECT_EQ(r.string(), "kidney");
  Eigen::MatrixXd dynamic;
  r.matrix(dynamic, 4, 3);
  EXPECT_EQ(dynamic, Eigen::MatrixXd(tall));
  Eigen::Matrix3d back;
  r.matrix(back);
  EXPECT_EQ(back, fixed.transpose());
  Eigen::MatrixXd empty;
  r.matrix(empty);
  EXPECT_EQ(empty.rows(), 0);
  EXPECT_EQ(empty.cols(), 5);
  EXPECT_EQ(r.remaining, 0u);
}

TEST(BinaryIo, AShapeOtherThanTheOneExpectedIsRefused) {
  // A cache's matrices have known shapes: a file that says otherwise is corrupt, whether the shape
  // comes from the caller, from the type's fixed size, or from its largest size.
  auto refused = [](auto&& read) {
    Stream s;
    s.writer().matrix(Eigen::MatrixXd::Ones(4, 30));
    auto r = s.reader();
    EXPECT_THROW(read(r), Error);
  };
  refused([](bin::Reader& r) {
    Eigen::MatrixXd m;
    r.matrix(m, 4, 29);
  });
  refused([](bin::Reader& r) {
    Eigen::Matrix<double, 4, 4> m;
    r.matrix(m);
  });
  refused([](bin::Reader& r) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 24, 24> m;  // at most 24 x 24
    r.matrix(m);
  });
}

TEST(BinaryIo, TruncatedOrOversizedCountsThrowWithoutAllocating) {
  Stream s;
  auto w = s.writer();
  w.pod(std::uint64_t(1) << 60);  // a vector's count far beyond the file
  auto r = s.reader();
  EXPECT_THROW(r.podVector<double>(), Error);
  Stream t;
  t.writer().string("a string cut short");
  std::string bytes = t.bytes.str();
  bytes.resize(bytes.size() - 4);
  std::stringstream cut(bytes);
  bin::Reader rc{cut, bytes.size()};
  EXPECT_THROW(rc.string(), Error);
  Stream m;
  m.writer().matrix(Eigen::MatrixXd::Ones(3, 3));
  bytes = m.bytes.str();
  bytes.resize(bytes.size() - 8);
  std::stringstream cutMatrix(bytes);
  bin::Reader rm{cutMatrix, bytes.size()};
  Eigen::MatrixXd read;
  EXPECT_THROW(rm.matrix(read), Error);
}

}  // namespace
}  // namespace handson
