#include "app/io/forces_json.h"

#include <cstdio>
#include <fstream>
#include <sstream>

#include "sim/base/atomic_file.h"
#include "sim/base/error.h"

namespace handson {

namespace {

std::string triple(const Eigen::Vector3d& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "[%.9g, %.9g, %.9g]", v.x(), v.y(), v.z());
  return buf;
}

}  // namespace

void writeForcesJson(const std::string& path, const std::vector<HandleReaction>& reactions, const std::string& model, const std::vector<int>& ids) {
  std::ostringstream os;
  os << "{\n  \"model\": \"" << model << "\",\n"
     << "  \"units\": {\"force\": \"N\", \"torque\": \"N mm\", \"position\": \"mm\", \"frame\": \"RAS\"},\n"
     << "  \"handles\": [";
  for (std::size_t k = 0; k < reactions.size(); ++k) {
    const auto& r = reactions[k];
    if (!r.forceN.allFinite() || !r.torqueNmm.allFinite() || !r.centreMm.allFinite()) throw Error("forces: a handle's reaction is not finite");
    os << (k ? ",\n" : "\n") << "    {";
    if (k < ids.size()) os << "\"id\": " << ids[k] << ", ";
    os << "\"force_N\": " << triple(r.forceN) << ", \"torque_Nmm\": " << triple(r.torqueNmm) << ", \"centre_mm\": " << triple(r.centreMm) << "}";
  }
  os << "\n  ]\n}\n";
  AtomicFile file(path);
  {
    std::ofstream out(file.tempPath(), std::ios::binary);
    out << os.str();
    out.flush();
    if (!out) throw Error("cannot write '" + path + "'");
  }
  file.commit();
}

}  // namespace handson
