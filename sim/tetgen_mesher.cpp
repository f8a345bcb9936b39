#include "tetgen_mesher.h"

#include <Eigen/Dense>
#include <sys/types.h>
#include "sim/base/child_process.h"
#include "sim/base/error.h"
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>

#define TETLIBRARY  // the library entry point; errors throw instead of calling exit()
#include <tetgen.h>

namespace handson {

namespace {

// Why the input cannot be meshed (empty: it can).
std::string inputProblem(const std::vector<Eigen::Vector3d>& points, const std::vector<std::array<int, 3>>& triangles) {
  if (points.size() < 4 || triangles.size() < 4) return "fewer than 4 points or 4 surface triangles";
  for (const auto& p : points)
    if (!p.allFinite()) return "a point is not finite";
  for (const auto& t : triangles)
    for (int v : t)
      if (v < 0 || std::size_t(v) >= points.size()) return "a surface triangle refers to a missing point";
  return {};
}

// The points and the surface triangles as TetGen's input (a piecewise linear complex).
void fillInput(tetgenio& in, const std::vector<Eigen::Vector3d>& points, const std::vector<std::array<int, 3>>& triangles) {
  in.firstnumber = 0;
  in.numberofpoints = int(points.size());
  in.pointlist = new REAL[points.size() * 3];
  for (std::size_t i = 0; i < points.size(); ++i)
    for (int c = 0; c < 3; ++c) in.pointlist[3 * i + std::size_t(c)] = points[i][c];
  in.numberoffacets = int(triangles.size());
  in.facetlist = new tetgenio::facet[triangles.size()];
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    tetgenio::facet& f = in.facetlist[i];
    tetgenio::init(&f);
    f.numberofpolygons = 1;
    f.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&f.polygonlist[0]);
    f.polygonlist[0].numberofvertices = 3;
    f.polygonlist[0].vertexlist = new int[3];
    for (int c = 0; c < 3; ++c) f.polygonlist[0].vertexlist[c] = triangles[i][std::size_t(c)];
  }
}

// In the child: TetGen on `in`, its answer as one frame [status i32][count i32][count tet corners i32]:
// status 0 done, 1 TetGen failed, 2 it added points (indices would not be the input's).
int tetrahedralizeInChild(tetgenio& in, ChildWriter& w) {
  // Never destroyed: TetGen's error path may leave it half-freed, and the child exits right after
  // its answer is written (a crash in its destructor would turn a good answer into a failure).
  tetgenio& out = *new tetgenio;
  int status = 1;
  std::vector<std::int32_t> msg;
  try {
    char switches[] = "pYQJ";  // PLC, boundary unsplit, quiet, keep every input point (indices stable)
    tetrahedralize(switches, &in, &out);
    bool same = out.numberofpoints == in.numberofpoints && out.numberofcorners == 4;
    for (int i = 0; same && i < 3 * in.numberofpoints; ++i) same = out.pointlist[i] == in.pointlist[i];
    if (!same) {
      status = 2;
    } else {
      status = 0;
      msg.assign(out.tetrahedronlist, out.tetrahedronlist + 4 * std::size_t(out.numberoftetrahedra));
    }
  } catch (...) {
    status = 1;
  }
  const std::int32_t head[2] = {status, std::int32_t(msg.size())};
  std::string frame(reinterpret_cast<const char*>(head), sizeof head);
  frame.append(reinterpret_cast<const char*>(msg.data()), msg.size() * sizeof(std::int32_t));
  return w.frame(0, frame) ? 0 : 3;
}

// The child's frame as tet corners; empty with `problem` set when it says TetGen did not mesh.
std::vector<std::int32_t> decodeChildAnswer(const std::string& bytes, int exitCode, std::size_t points, std::string& problem) {
  std::int32_t head[2] = {-1, 0};
  if (bytes.size() >= sizeof head) std::memcpy(head, bytes.data(), sizeof head);
  if (exitCode != 0 || bytes.size() < sizeof head) problem = "TetGen failed (it stopped in its error path)";
  else if (head[0] == 1) problem = "TetGen failed";
  else if (head[0] == 2) problem = "TetGen needed extra points to keep the surface";
  else if (head[0] != 0 || head[1] <= 0 || head[1] % 4 != 0 || bytes.size() != sizeof head + std::size_t(head[1]) * sizeof(std::int32_t))
    problem = "TetGen returned no tets";
  if (!problem.empty()) return {};
  std::vector<std::int32_t> tl(static_cast<std::size_t>(head[1]));
  std::memcpy(tl.data(), bytes.data() + sizeof head, tl.size() * sizeof(std::int32_t));
  for (std::int32_t v : tl)
    if (v < 0 || std::size_t(v) >= points) {
      problem = "TetGen returned a tet with a missing point";
      return {};
    }
  return tl;
}

// The tets, each turned positive; false (r.message set, no tets) when one is flat.
bool orientTets(const std::vector<Eigen::Vector3d>& points, const std::vector<std::int32_t>& tl, TetgenResult& r) {
  r.tets.resize(tl.size() / 4);
  for (std::size_t t = 0; t < r.tets.size(); ++t) {
    auto& tet = r.tets[t];
    for (int c = 0; c < 4; ++c) tet[std::size_t(c)] = tl[4 * t + std::size_t(c)];
    Eigen::Matrix3d D;
    D << points[std::size_t(tet[1])] - points[std::size_t(tet[0])], points[std::size_t(tet[2])] - points[std::size_t(tet[0])],
        points[std::size_t(tet[3])] - points[std::size_t(tet[0])];
    double det = D.determinant();
    if (det < 0) {
      std::swap(tet[2], tet[3]);
      det = -det;
    }
    const double scale = std::pow(std::max({D.col(0).norm(), D.col(1).norm(), D.col(2).norm()}), 3);
    if (!(det > 1e-12 * scale)) {
      r.message = "TetGen produced a flat tet";
      r.tets.clear();
      return false;
    }
  }
  return true;
}

}  // namespace

TetgenResult tetrahedralizeSurface(const std::vector<Eigen::Vector3d>& points, const std::vector<std::array<int, 3>>& triangles) {
  TetgenResult r;
  r.message = inputProblem(points, triangles);
  if (!r.message.empty()) return r;
  tetgenio in;
  fillInput(in, points, triangles);
  // TetGen 1.5's error path frees its mesh and throws, and the unwinding frees it again: any TetGen
  // error would crash this process. So TetGen runs in a forked child that sends its tets back
  // through a pipe; a child that crashes or fails is a status here. (A fork per call costs about a
  // millisecond; each child also has its own copy of TetGen's global state, so threads may call this.)
  std::string bytes;
  ChildEnd end;
  try {
    end = runInChild([&](ChildWriter& w) { return tetrahedralizeInChild(in, w); },
                     [&](ChildReader& reader) {
                       std::uint8_t kind = 0;
                       if (!reader.frame(kind, bytes)) bytes.clear();
                     },
                     0.0, "TetGen not run");
  } catch (const Error& e) {  // no pipe, no child process
    r.message = e.what();
    return r;
  }
  const std::vector<std::int32_t> tl = decodeChildAnswer(bytes, end.exitCode, points.size(), r.message);
  if (!r.message.empty()) return r;
  r.ok = orientTets(points, tl, r);
  return r;
}

}  // namespace handson
