#include "nrrd_io.h"

#include <teem/nrrd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "sim/base/atomic_file.h"
#include "app/io/volume_import.h"
#include "sim/base/error.h"

namespace handson {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw Error("Cannot read NRRD file '" + path + "': " + what); }

// Teem's accumulated error text for its nrrd library, taken (and cleared).
std::string teemError() {
  char* e = biffGetDone(NRRD);
  std::string s = e ? e : "unknown error";
  std::free(e);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

struct NrrdDeleter {
  void operator()(Nrrd* n) const { nrrdNuke(n); }
};
struct IoDeleter {
  void operator()(NrrdIoState* s) const { nrrdIoStateNix(s); }
};

template <class T> double load(const void* data, std::size_t i) {
  T v;
  std::memcpy(&v, static_cast<const char*>(data) + i * sizeof(T), sizeof(T));
  return double(v);
}

double valueAt(const Nrrd* n, std::size_t i) {
  switch (n->type) {
    case nrrdTypeChar: return load<std::int8_t>(n->data, i);
    case nrrdTypeUChar: return load<std::uint8_t>(n->data, i);
    case nrrdTypeShort: return load<std::int16_t>(n->data, i);
    case nrrdTypeUShort: return load<std::uint16_t>(n->data, i);
    case nrrdTypeInt: return load<std::int32_t>(n->data, i);
    case nrrdTypeUInt: return load<std::uint32_t>(n->data, i);
    case nrrdTypeLLong: return load<std::int64_t>(n->data, i);
    case nrrdTypeULLong: return load<std::uint64_t>(n->data, i);
    case nrrdTypeFloat: return load<float>(n->data, i);
    case nrrdTypeDouble: return load<double>(n->data, i);
    default: return std::nan("");
  }
}

// RAS+ from the file's space: the signs of x and y.
Eigen::Vector3d toRasSigns(int space) {
  switch (space) {
    case nrrdSpaceLeftPosteriorSuperior:
    case nrrdSpaceLeftPosteriorSuperiorTime:
    case nrrdSpaceScannerXYZ:
    case nrrdSpaceScannerXYZTime: return {-1, -1, 1};
    case nrrdSpaceLeftAnteriorSuperior:
    case nrrdSpaceLeftAnteriorSuperiorTime: return {-1, 1, 1};
    default: return {1, 1, 1};
  }
}

struct Layout {
  std::vector<unsigned> spatial;  // axis indices, in file order
  int frameAxis = -1;
  std::int64_t frames = 1;
};

Layout axesOf(const Nrrd* n, const std::string& path) {
  Layout l;
  for (unsigned a = 0; a < n->dim; ++a) {
    const bool spatial = n->spaceDim > 0 ? std::isfinite(n->axis[a].spaceDirection[0]) : true;
    if (spatial) {
      l.spatial.push_back(a);
    } else if (n->axis[a].size > 1) {
      if (l.frameAxis >= 0) fail(path, "more than one non-spatial axis (only one list, vector or time axis can be read)");
      l.frameAxis = int(a);
      l.frames = std::int64_t(n->axis[a].size);
    }
  }
  if (n->spaceDim == 0 && l.spatial.size() > 3) {  // no space: a 4th axis counts volumes
    l.frameAxis = int(l.spatial.back());
    l.frames = std::int64_t(n->axis[l.frameAxis].size);
    l.spatial.pop_back();
  }
  if (l.spatial.size() < 2 || l.spatial.size() > 3)
    fail(path, std::to_string(l.spatial.size()) + " spatial axes: only 2D and 3D images can be read");
  // A 2D image may live in a 2D space (ITK writes such files): its plane is z = 0.
  if (n->spaceDim != 0 && n->spaceDim != 3 && !(n->spaceDim == 2 && l.spatial.size() == 2))
    fail(path, "a " + std::to_string(n->spaceDim) + "-dimensional space (3, or 2 for a 2D image, is expected)");
  return l;
}

VolumeGeometry geometryOf(const Nrrd* n, const Layout& l, const std::string& path) {
  VolumeGeometry g;
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  for (std::size_t c = 0; c < l.spatial.size(); ++c) {
    const NrrdAxisInfo& ax = n->axis[l.spatial[c]];
    if (ax.size > std::size_t(std::numeric_limits<int>::max())) fail(path, "an axis of " + std::to_string(ax.size) + " samples is too large");
    g.dims[Eigen::Index(c)] = int(ax.size);
    if (n->spaceDim > 0) {
      for (unsigned r = 0; r < n->spaceDim; ++r) a(r, Eigen::Index(c)) = ax.spaceDirection[r];
    } else {
      a(Eigen::Index(c), Eigen::Index(c)) = std::isfinite(ax.spacing) && ax.spacing != 0.0 ? std::abs(ax.spacing) : 1.0;
    }
  }
  if (l.spatial.size() == 2) {
    g.dims.z() = 1;
    const Eigen::Vector3d normal = Eigen::Vector3d(a.col(0)).cross(Eigen::Vector3d(a.col(1)));
    a.col(2) = normal.norm() > 0 ? Eigen::Vector3d(normal.normalized()) : Eigen::Vector3d::UnitZ();
  }
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (unsigned r = 0; r < n->spaceDim; ++r) origin[r] = std::isfinite(n->spaceOrigin[r]) ? n->spaceOrigin[r] : 0.0;
  const Eigen::Vector3d sign = toRasSigns(n->space);
  try {
    return geometryFromAxes(sign.asDiagonal() * a, sign.cwiseProduct(origin) + Eigen::Vector3d::Zero(), g.dims);  // + 0: no -0
  } catch (const Error& e) {
    fail(path, e.what());
  }
}

// Teem allocates the data the header declares before it reads any: a raw, hex or ASCII file must
// hold at least that many bytes (found by fuzz_nrrd: a 269-byte file declaring 2.5 GB), and gzip
// cannot expand more than about 1032:1. (bzip2 can; its declared size is bounded by
// checkAllocation alone.)
void checkDataFits(const std::string& path, const NrrdIoState* io, double bytes) {
  namespace fs = std::filesystem;
  double have = 0;
  std::error_code ec;
  if (io->dataFNArr && io->dataFNArr->len > 0) {
    const fs::path dir = fs::path(path).parent_path();
    for (unsigned i = 0; i < io->dataFNArr->len; ++i) {
      const fs::path p = fs::path(io->dataFN[i]).is_absolute() ? fs::path(io->dataFN[i]) : dir / io->dataFN[i];
      const auto size = fs::file_size(p, ec);
      if (!ec) have += double(size);
    }
    if (io->dataFNArr->len > 0 && have == 0) return;  // a detached file Teem will report missing itself
  } else {
    const auto size = fs::file_size(path, ec);
    if (ec) return;
    have = double(size);
  }
  double most = -1;  // the largest data the file(s) can hold; < 0: no bound from the encoding
  if (io->encoding == nrrdEncodingRaw) most = have;
  else if (io->encoding == nrrdEncodingHex) most = have / 2;
  else if (io->encoding == nrrdEncodingAscii) most = have * 8;  // one digit and a separator per value, 8 bytes at most each
  else if (io->encoding == nrrdEncodingGzip) most = have * 1100;
  if (most >= 0 && bytes > most)
    fail(path, "its header declares " + std::to_string(std::llround(bytes)) + " bytes of data but the file holds only " + std::to_string(std::llround(have)) +
                   " bytes: it is truncated or its sizes are wrong");
}

}  // namespace

Volume readNrrd(const std::string& path, std::int64_t frame, NrrdInfo* info) {
  // The header alone first: sizes are checked before Teem allocates the data.
  std::unique_ptr<NrrdIoState, IoDeleter> io(nrrdIoStateNew());
  io->skipData = 1;
  std::unique_ptr<Nrrd, NrrdDeleter> head(nrrdNew());
  if (nrrdLoad(head.get(), path.c_str(), io.get())) fail(path, teemError());
  const Layout layout = axesOf(head.get(), path);
  const VolumeGeometry geometry = geometryOf(head.get(), layout, path);
  if (frame < 0 || frame >= layout.frames)
    fail(path, "volume " + std::to_string(frame) + " was asked for, but the image holds " + std::to_string(layout.frames) + " volume" +
                   (layout.frames == 1 ? "" : "s") + (layout.frames > 1 ? " (--frame takes 0 to " + std::to_string(layout.frames - 1) + ")" : ""));
  if (nrrdTypeSize[head->type] == 0 || head->type == nrrdTypeBlock) fail(path, "its sample type is not a number");
  const double elements = double(geometry.voxelCount()) * double(layout.frames);
  try {
    checkAllocation(geometry.voxelCount(), std::size_t(std::min(elements * double(nrrdTypeSize[head->type]), 1e18)), "the NRRD image");
  } catch (const Error& e) {
    fail(path, e.what());
  }

  checkDataFits(path, io.get(), elements * double(nrrdTypeSize[head->type]));

  std::unique_ptr<Nrrd, NrrdDeleter> n(nrrdNew());
  if (nrrdLoad(n.get(), path.c_str(), nullptr)) fail(path, teemError());
  if (n->dim != head->dim || n->type != head->type) fail(path, "the file changed while it was read");
  if (info) {
    info->frames = layout.frames;
    info->space = n->space > 0 && n->space <= NRRD_SPACE_MAX ? airEnumStr(nrrdSpace, n->space) : "";
  }

  // Strides of the file's axes (axis 0 fastest).
  std::vector<std::size_t> stride(n->dim, 1);
  for (unsigned a = 1; a < n->dim; ++a) stride[a] = stride[a - 1] * n->axis[a - 1].size;
  const std::size_t base = layout.frameAxis >= 0 ? std::size_t(frame) * stride[std::size_t(layout.frameAxis)] : 0;
  std::array<std::size_t, 3> s{0, 0, 0};
  for (std::size_t c = 0; c < layout.spatial.size(); ++c) s[c] = stride[layout.spatial[c]];
  const Eigen::Vector3i d = geometry.dims;
  auto sourceIndex = [&](std::size_t i) {
    const std::size_t x = i % std::size_t(d.x()), y = (i / std::size_t(d.x())) % std::size_t(d.y()), z = i / (std::size_t(d.x()) * std::size_t(d.y()));
    return base + x * s[0] + y * s[1] + z * s[2];
  };
  return volumeFromValues(geometry, n->type == nrrdTypeUChar, n->type != nrrdTypeFloat && n->type != nrrdTypeDouble,
                          [&](std::size_t i) { return valueAt(n.get(), sourceIndex(i)); });
}

void writeNrrd(const Volume& volume, const std::string& path) {
  if (volume.empty()) throw Error("Cannot write NRRD file '" + path + "': the volume is empty");
  AtomicFile out(path);
  const VolumeGeometry& g = volume.geometry();
  const int type = volume.type() == ScalarType::UInt8 ? nrrdTypeUChar : volume.type() == ScalarType::Int16 ? nrrdTypeShort : nrrdTypeFloat;
  std::unique_ptr<Nrrd, NrrdDeleter> n(nrrdNew());
  // Teem writes from our buffer without taking it (nrrdNix, not nrrdNuke, afterwards).
  const std::size_t sizes[3] = {std::size_t(g.dims.x()), std::size_t(g.dims.y()), std::size_t(g.dims.z())};
  if (nrrdWrap_nva(n.get(), const_cast<std::byte*>(volume.bytes()), type, 3, sizes)) {
    const std::string e = teemError();
    nrrdNix(n.release());
    throw Error("Cannot write NRRD file '" + path + "': " + e);
  }
  const Eigen::Vector3d lps(-1, -1, 1);
  nrrdSpaceSet(n.get(), nrrdSpaceLeftPosteriorSuperior);
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d d = lps.cwiseProduct(g.direction.col(c)) * g.spacing[c];
    for (int r = 0; r < 3; ++r) n->axis[c].spaceDirection[r] = d[r];
    n->axis[c].kind = nrrdKindDomain;
  }
  const Eigen::Vector3d o = lps.cwiseProduct(g.origin);
  const double origin[3] = {o.x(), o.y(), o.z()};
  nrrdSpaceOriginSet(n.get(), origin);
  std::unique_ptr<NrrdIoState, IoDeleter> io(nrrdIoStateNew());
  io->format = nrrdFormatNRRD;
  io->encoding = nrrdEncodingGzip;
  const int failed = nrrdSave(out.tempPath().c_str(), n.get(), io.get());
  const std::string e = failed ? teemError() : std::string();
  nrrdNix(n.release());
  if (failed) throw Error("Cannot write NRRD file '" + path + "': " + e);
  out.commit();
}

}  // namespace handson
