#include "vtu_io.h"

#include <cstdio>
#include <fstream>
#include <iomanip>

#include "sim/base/atomic_file.h"
#include "sim/base/error.h"

namespace handson {

void writeVtu(const std::string& path, const TetMesh& mesh, const VtuArrays& a) {
  for (const auto& [name, v] : a.pointVectors)
    if (v->size() != mesh.nodes.size()) throw Error("vtu: point array '" + name + "' has the wrong size");
  for (const auto& [name, v] : a.pointScalars)
    if (v->size() != mesh.nodes.size()) throw Error("vtu: point array '" + name + "' has the wrong size");
  for (const auto& [name, v] : a.cellScalars)
    if (v->size() != mesh.tets.size()) throw Error("vtu: cell array '" + name + "' has the wrong size");
  AtomicFile file(path);
  {
    std::ofstream out(file.tempPath());
    out << std::setprecision(9);
    out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n";
    out << "<Piece NumberOfPoints=\"" << mesh.nodes.size() << "\" NumberOfCells=\"" << mesh.tets.size() << "\">\n";
    out << "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
    for (const auto& p : mesh.nodes) out << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
    out << "</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
    for (const auto& t : mesh.tets) out << t[0] << ' ' << t[1] << ' ' << t[2] << ' ' << t[3] << '\n';
    out << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
    for (std::size_t i = 0; i < mesh.tets.size(); ++i) out << 4 * (i + 1) << '\n';
    out << "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
    for (std::size_t i = 0; i < mesh.tets.size(); ++i) out << "10\n";  // VTK_TETRA
    out << "</DataArray>\n</Cells>\n<PointData>\n";
    for (const auto& [name, v] : a.pointVectors) {
      out << "<DataArray type=\"Float64\" Name=\"" << name << "\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (const auto& p : *v) out << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
      out << "</DataArray>\n";
    }
    for (const auto& [name, v] : a.pointScalars) {
      out << "<DataArray type=\"Float64\" Name=\"" << name << "\" format=\"ascii\">\n";
      for (double s : *v) out << s << '\n';
      out << "</DataArray>\n";
    }
    out << "</PointData>\n<CellData>\n";
    for (const auto& [name, v] : a.cellScalars) {
      out << "<DataArray type=\"Float64\" Name=\"" << name << "\" format=\"ascii\">\n";
      for (double s : *v) out << s << '\n';
      out << "</DataArray>\n";
    }
    out << "</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
    out.flush();
    if (!out) throw Error("cannot write '" + path + "': write failed (disk full?)");
  }
  file.commit();
}

}  // namespace handson
