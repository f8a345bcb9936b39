#pragma once
// The session's state on disk: the handles (which voxels each holds, its status and its pose) as a
// documented JSON file, and the recovery save that keeps a session when something fails under it
// (a Vulkan allocation failure, a lost device, a simulation that does not converge).
//
// Handles file (format "handson-handles", version 1):
// {
//   "format": "handson-handles", "version": 1,
//   "dims": [nx, ny, nz],                         // the grid the voxel indices refer to
//   "picked": [3, 1],                             // handles picked by a tap, most recent last
//   "handles": [
//     {"id": 1, "status": "active",              // active | fixed | idle
//      "voxels": 2348,                           // count, checked against the runs
//      "runs": [[start, length], ...],           // sorted linear indices (i + nx (j + ny k)) at rest
//      "rotation": [r00, r01, r02, r10, ..., r22], "translation": [x, y, z]}   // the pose, mm
//   ]
// }
#include <Eigen/Core>
#include <string>
#include <vector>

#include "interaction/handles.h"

namespace handson {

class Session;

struct SavedHandles {
  Eigen::Vector3i dims{0, 0, 0};
  std::vector<Handle> handles;
  std::vector<int> picked;
};

std::string formatHandles(const HandleSet& handles, const std::vector<int>& picked, const Eigen::Vector3i& dims);
/// Written atomically (temporary file renamed into place).
void writeHandles(const HandleSet& handles, const std::vector<int>& picked, const Eigen::Vector3i& dims, const std::string& path);
/// Parses a handles file; throws handson::Error naming `name` and the problem (bad JSON, another
/// format or version, ids out of range or repeated, runs unsorted, overlapping or outside the grid,
/// a count that does not match, a pose that is not finite or not a rotation).
SavedHandles parseHandles(const std::string& text, const std::string& name = "handles");
SavedHandles readHandles(const std::string& path);

/// Saves the session so far after a failure: `dir`/recovery-session.json (the script of every event
/// applied, replayable with `handson replay`) and `dir`/recovery-handles.json, each atomically (a
/// later save replaces them whole). Never throws: returns the sentence to show the user, naming the
/// files, or saying why they could not be written.
std::string saveRecovery(const Session& session, const HandleSet& handles, const std::vector<int>& picked,
                         const Eigen::Vector3i& dims, const std::string& dir);

}  // namespace handson
