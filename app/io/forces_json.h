#pragma once
// The handles' reactions as JSON (`handson deform --forces-out`, the Export action):
//   {"model": "coarse", "units": {...}, "handles": [{"id": 1, "force_N": [x, y, z],
//    "torque_Nmm": [x, y, z], "centre_mm": [x, y, z]}, ...]}
// in world (RAS) coordinates: the force the tissue exerts on each handle and its moment about the
// handle's current centroid (sim/handle_reaction.h). Written atomically.
#include <string>
#include <vector>

#include "sim/handle_reaction.h"

namespace handson {

/// `model`: which model the reactions come from ("coarse", "refined", "fine"); `ids`: the app's
/// handle id of each (written as "id" when given). Throws handson::Error when the file cannot be
/// written or a value is not finite.
void writeForcesJson(const std::string& path, const std::vector<HandleReaction>& reactions, const std::string& model, const std::vector<int>& ids = {});

}  // namespace handson
