#pragma once
// Little binary streams for the on-disk caches (sim/scene_cache.h): plain values, Eigen matrices and
// vectors of them, in the machine's byte order (a cache is local to the machine that wrote it; its
// header records the order and the format version). Reads are bounded: a truncated or corrupt
// file throws handson::Error, never over-allocates.
#include <Eigen/Core>
#include <cstdint>
#include <cstring>
#include <istream>
#include <ostream>
#include <string>
#include <type_traits>
#include <vector>

#include "sim/error.h"

namespace handson::bin {

// Fixed-size Eigen matrices are plain arrays of scalars (memcpy-safe), though not "trivially
// copyable" by the trait.
template <class T>
struct Plain : std::bool_constant<std::is_trivially_copyable_v<T>> {};
template <class S, int R, int C, int O, int MR, int MC>
struct Plain<Eigen::Matrix<S, R, C, O, MR, MC>> : std::bool_constant<(R > 0 && C > 0)> {};

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
  template <class M>
  void matrix(const M& m) {
    pod(std::int64_t(m.rows()));
    pod(std::int64_t(m.cols()));
    const Eigen::Matrix<typename M::Scalar, Eigen::Dynamic, Eigen::Dynamic> d = m;
    os.write(reinterpret_cast<const char*>(d.data()), std::streamsize(d.size() * sizeof(typename M::Scalar)));
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
  /// A matrix of `rows` x `cols` (-1: any), checked against what the file says.
  template <class M>
  void matrix(M& m, Eigen::Index rows = -1, Eigen::Index cols = -1) {
    const auto r = pod<std::int64_t>(), c = pod<std::int64_t>();
    if (r < 0 || c < 0 || (rows >= 0 && r != rows) || (cols >= 0 && c != cols) || (r && std::uint64_t(c) > remaining / std::uint64_t(r)))
      throw Error("cache file corrupt (a matrix of the wrong shape)");
    need(std::uint64_t(r) * std::uint64_t(c) * sizeof(typename M::Scalar));
    Eigen::Matrix<typename M::Scalar, Eigen::Dynamic, Eigen::Dynamic> d(r, c);
    if (d.size() && !is.read(reinterpret_cast<char*>(d.data()), std::streamsize(d.size() * sizeof(typename M::Scalar))))
      throw Error("cache file truncated");
    m = d;
  }
};

}  // namespace handson::bin
