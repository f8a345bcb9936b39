#include "tetgen_mesher.h"

#include <Eigen/Dense>
#include <sys/types.h>
#include "sim/child_process.h"
#include "sim/error.h"
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

TetgenResult tetrahedralizeSurface(const std::vector<Eigen::Vector3d>& points, const std::vector<std::array<int, 3>>& triangles) {
  TetgenResult r;
  if (points.size() < 4 || triangles.size() < 4) {
    r.message = "fewer than 4 points or 4 surface triangles";
    return r;
  }
  for (const auto& p : points)
    if (!p.allFinite()) {
      r.message = "a point is not finite";
      return r;
    }
  for (const auto& t : triangles)
    for (int v : t)
      if (v < 0 || std::size_t(v) >= points.size()) {
        r.message = "a surface triangle refers to a missing point";
        return r;
      }
  tetgenio in, out;
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
  // TetGen 1.5's error path frees its mesh and throws, and the unwinding frees it again: any TetGen
  // error would crash this process. So TetGen runs in a forked child that sends its tets back
  // through a pipe; a child that crashes or fails is a status here. (A fork per call costs about a
  // millisecond; each child also has its own copy of TetGen's global state, so threads may call this.)
  std::string bytes;
  ChildEnd end;
  try {
    end = runInChild(
        [&](ChildWriter& w) {
          int status = 1;
          std::vector<std::int32_t> msg;
          try {
            char switches[] = "pYQJ";  // PLC, boundary unsplit, quiet, keep every input point (indices stable)
            tetrahedralize(switches, &in, &out);
            bool same = out.numberofpoints == in.numberofpoints && out.numberofcorners == 4;
            for (int i = 0; same && i < 3 * in.numberofpoints; ++i) same = out.pointlist[i] == in.pointlist[i];
            if (!same) status = 2;
            else {
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
        },
        [&](ChildReader& reader) {
          std::uint8_t kind = 0;
          if (!reader.frame(kind, bytes)) bytes.clear();
        },
        0.0, "TetGen not run");
  } catch (const Error& e) {  // no pipe, no child process
    r.message = e.what();
    return r;
  }
  std::int32_t head[2] = {-1, 0};
  if (bytes.size() >= sizeof head) std::memcpy(head, bytes.data(), sizeof head);
  if (end.exitCode != 0 || bytes.size() < sizeof head) {
    r.message = "TetGen failed (it stopped in its error path)";
    return r;
  }
  if (head[0] == 1) {
    r.message = "TetGen failed";
    return r;
  }
  if (head[0] == 2) {
    r.message = "TetGen needed extra points to keep the surface";
    return r;
  }
  if (head[0] != 0 || head[1] <= 0 || head[1] % 4 != 0 || bytes.size() != sizeof head + std::size_t(head[1]) * sizeof(std::int32_t)) {
    r.message = "TetGen returned no tets";
    return r;
  }
  std::vector<std::int32_t> tl(static_cast<std::size_t>(head[1]));
  std::memcpy(tl.data(), bytes.data() + sizeof head, tl.size() * sizeof(std::int32_t));
  for (std::int32_t v : tl)
    if (v < 0 || std::size_t(v) >= points.size()) {
      r.message = "TetGen returned a tet with a missing point";
      return r;
    }
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
      return r;
    }
  }
  r.ok = true;
  return r;
}

}  // namespace handson
