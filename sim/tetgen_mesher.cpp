#include "tetgen_mesher.h"

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
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
  char switches[] = "pYQ";
  try {
    tetrahedralize(switches, &in, &out);
  } catch (int code) {
    r.message = "TetGen failed (code " + std::to_string(code) + ")";
    return r;
  } catch (const std::exception& e) {
    r.message = std::string("TetGen failed: ") + e.what();
    return r;
  }
  if (out.numberofpoints != in.numberofpoints) {
    r.message = "TetGen needed " + std::to_string(out.numberofpoints - in.numberofpoints) + " extra points to keep the surface";
    return r;
  }
  if (out.numberofcorners != 4 || out.numberoftetrahedra <= 0) {
    r.message = "TetGen returned no linear tets";
    return r;
  }
  r.tets.resize(std::size_t(out.numberoftetrahedra));
  for (std::size_t t = 0; t < r.tets.size(); ++t) {
    auto& tet = r.tets[t];
    for (int c = 0; c < 4; ++c) tet[std::size_t(c)] = out.tetrahedronlist[4 * t + std::size_t(c)];
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
