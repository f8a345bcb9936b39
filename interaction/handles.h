#pragma once
// Handles: selected regions of the volume that the user manipulates (docs/touch-app.md).
// Each handle keeps its voxels (linear indices on the volume grid); a voxel belongs to one handle
// only, the last one that claimed it. Union and difference combine two handles. Status: active
// (follows the manipulation), fixed (held in place) or idle (kept for later). Every edit can be
// undone and redone.
#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "sim/rigid_transform.h"

namespace handson {

enum class HandleStatus : std::uint8_t { Active, Fixed, Idle };
const char* handleStatusName(HandleStatus s);
bool parseHandleStatus(const std::string& s, HandleStatus& out);

struct Handle {
  int id = 0;                        ///< 1..254 (0: none; 255: the live selection)
  HandleStatus status = HandleStatus::Active;
  std::vector<std::uint32_t> voxels;  ///< sorted linear indices (rest position)
  RigidTransform pose;                ///< cumulative rigid transform from the manipulation (R_m, t_m)
};

class HandleSet {
 public:
  static constexpr int kLiveSelectionId = 255;
  static constexpr int kMaxHandles = 254;

  /// A new active handle from voxels (claimed from any other handle). Returns its id, or 0 if
  /// refused (no voxels, or no free id).
  int add(std::vector<std::uint32_t> voxels);
  bool remove(int id);
  bool setStatus(int id, HandleStatus s);
  /// a := a ∪ b, b removed. False if either is missing or a == b.
  bool unite(int a, int b);
  /// a := a \ b (b unchanged). False if either is missing, a == b, or nothing would remain of a.
  bool subtract(int a, int b);
  /// Sets a handle's pose; `undoable` makes it an undo step (once per gesture, not per event).
  bool setPose(int id, const RigidTransform& pose, bool undoable);
  bool undo();
  bool redo();
  bool canUndo() const { return !undo_.empty(); }
  bool canRedo() const { return !redo_.empty(); }

  const std::vector<Handle>& handles() const { return handles_; }
  const Handle* find(int id) const;
  /// Tint per id for the raymarch (gpu::kMaxHandleIds entries): active warm, fixed blue, idle grey,
  /// the live selection bright green; `highlight` (a picked handle) is drawn stronger.
  std::vector<glm::vec4> tints(int highlight = 0) const;
  /// Every voxel whose handle id changed since `before` (for partial mask uploads).
  static std::vector<std::uint32_t> changedVoxels(const std::vector<Handle>& before, const std::vector<Handle>& after);

 private:
  void snapshot();
  Handle* get(int id);
  std::vector<Handle> handles_;
  std::vector<std::vector<Handle>> undo_, redo_;
};

}  // namespace handson
