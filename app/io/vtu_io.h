#pragma once
// VTK XML unstructured grid (.vtu, ASCII) for the simulation meshes: ParaView opens it. Points are
// the rest positions; point data and cell data are named arrays.
#include <string>
#include <utility>
#include <vector>

#include "sim/tet_mesh.h"

namespace handson {

struct VtuArrays {
  std::vector<std::pair<std::string, const std::vector<Eigen::Vector3d>*>> pointVectors;
  std::vector<std::pair<std::string, const std::vector<double>*>> pointScalars;
  std::vector<std::pair<std::string, const std::vector<double>*>> cellScalars;
};

/// Writes atomically (a failure leaves no partial file). Throws handson::Error on size mismatches
/// or I/O failure.
void writeVtu(const std::string& path, const TetMesh& mesh, const VtuArrays& arrays);

}  // namespace handson
