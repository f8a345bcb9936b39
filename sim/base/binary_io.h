#pragma once
// Little binary streams for the on-disk caches (sim/scene_cache.h) and the readers' isolated calls:
// plain values, dense matrices (Eigen's, recognised by their members: this header includes no
// Eigen) and vectors of them, in the machine's byte order (a cache is local to the machine that
// wrote it; its header records the order and the format version). Reads are bounded: a truncated
// or corrupt file throws handson::Error, never over-allocates.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <istream>
#include <ostream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "sim/base/error.h"

namespace handson::bin {

// A dense matrix type that is its own plain object (Eigen's Matrix and Array; not an expression),
// with its compile-time rows and columns (Eigen's Dynamic, -1, where they vary).
template <class T, class = void>
struct DenseMatrix : std::false_type {};
template <class T>
struct DenseMatrix<T, std::void_t<typename T::PlainObject, decltype(T::RowsAtCompileTime), decltype(T::ColsAtCompileTime)>>
    : std::bool_constant<std::is_same_v<T, typename T::PlainObject>> {};

// Fixed-size dense matrices are plain arrays of scalars (memcpy-safe), though not "trivially
// copyable" by the trait.
template <class T, class = void>
struct FixedMatrix : std::false_type {};
template <class T>
struct FixedMatrix<T, std::enable_if_t<DenseMatrix<T>::value>>
    : std::bool_constant<(int(T::RowsAtCompileTime) > 0 && int(T::ColsAtCompileTime) > 0)> {};

template <class T>
struct Plain : std::bool_constant<std::is_trivially_copyable_v<T> || FixedMatrix<T>::value> {};

// The bytes of a matrix are its scalars column after column: those of a column-major matrix (or of
// a single row) as they lie in memory.
template <class D>
constexpr bool columnOrder() {
  return !D::IsRowMajor || int(D::RowsAtCompileTime) == 1;
}

struct Writer {
  std::ostream& os;
  template <class T>
  void pod(const T& v) {
    static_assert(Plain<T>::value);
    os.write(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T>
  void podVector(const std::vector<T>& v) {
    static_assert(Plain<T>::value);
    pod(std::uint64_t(v.size()));
    if (!v.empty()) os.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
  }
  void string(const std::string& s) {
    pod(std::uint64_t(s.size()));
    os.write(s.data(), std::streamsize(s.size()));
  }
  /// Any dense matrix or expression: its rows, columns and scalars column after column (a
  /// row-major one, such as a transpose's, a scalar at a time).
  template <class M>
  void matrix(const M& m) {
    using D = typename M::PlainObject;
    pod(std::int64_t(m.rows()));
    pod(std::int64_t(m.cols()));
    const D d = m;
    if constexpr (columnOrder<D>()) {
      os.write(reinterpret_cast<const char*>(d.data()), std::streamsize(d.size() * sizeof(typename M::Scalar)));
    } else {
      for (std::int64_t c = 0; c < d.cols(); ++c)
        for (std::int64_t r = 0; r < d.rows(); ++r) pod(d(r, c));
    }
  }
};

struct Reader {
  std::istream& is;
  std::uint64_t remaining;  ///< bytes left in the file: no count may exceed it
  void need(std::uint64_t n) {
    if (n > remaining) throw Error("cache file truncated or corrupt");
    remaining -= n;
  }
  template <class T>
  T pod() {
    static_assert(Plain<T>::value);
    need(sizeof(T));
    T v;
    if (!is.read(reinterpret_cast<char*>(&v), sizeof v)) throw Error("cache file truncated");
    return v;
  }
  template <class T>
  std::vector<T> podVector() {
    const auto n = pod<std::uint64_t>();
    if (n > remaining / std::max<std::size_t>(sizeof(T), 1)) throw Error("cache file corrupt (a count beyond its size)");
    need(n * sizeof(T));
    std::vector<T> v(n);
    if (n && !is.read(reinterpret_cast<char*>(v.data()), std::streamsize(n * sizeof(T)))) throw Error("cache file truncated");
    return v;
  }
  std::string string() {
    const auto n = pod<std::uint64_t>();
    need(n);
    std::string s(n, '\0');
    if (n && !is.read(s.data(), std::streamsize(n))) throw Error("cache file truncated");
    return s;
  }
  /// A matrix of `rows` x `cols` (-1: any; a fixed-size dimension of M must match too), checked
  /// against what the file says. M is a column-major plain matrix (the caches' types).
  template <class M>
  void matrix(M& m, std::int64_t rows = -1, std::int64_t cols = -1) {
    static_assert(DenseMatrix<M>::value && columnOrder<M>());
    if ((int(M::RowsAtCompileTime) > 0 && rows >= 0 && rows != M::RowsAtCompileTime) || (int(M::ColsAtCompileTime) > 0 && cols >= 0 && cols != M::ColsAtCompileTime))
      throw Error("binary_io: a fixed-size matrix asked for with another shape");
    if (int(M::RowsAtCompileTime) > 0) rows = M::RowsAtCompileTime;
    if (int(M::ColsAtCompileTime) > 0) cols = M::ColsAtCompileTime;
    const auto r = pod<std::int64_t>(), c = pod<std::int64_t>();
    const bool overMax = (int(M::MaxRowsAtCompileTime) > 0 && r > M::MaxRowsAtCompileTime) || (int(M::MaxColsAtCompileTime) > 0 && c > M::MaxColsAtCompileTime);
    if (r < 0 || c < 0 || overMax || (rows >= 0 && r != rows) || (cols >= 0 && c != cols) || (r && std::uint64_t(c) > remaining / std::uint64_t(r)))
      throw Error("cache file corrupt (a matrix of the wrong shape)");
    need(std::uint64_t(r) * std::uint64_t(c) * sizeof(typename M::Scalar));
    M d;
    d.resize(r, c);
    if (d.size() && !is.read(reinterpret_cast<char*>(d.data()), std::streamsize(d.size() * sizeof(typename M::Scalar))))
      throw Error("cache file truncated");
    m = std::move(d);
  }
};

}  // namespace handson::bin
