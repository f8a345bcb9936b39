#pragma once
// Handles: selected regions of the volume that the user manipulates (docs/touch-app.md).
// Each handle keeps its voxels (linear indices on the volume grid); a voxel belongs to one handle
// only, the last one that claimed it. Union and difference combine two handles. Status: active
// (follows the manipulation), fixed (held in place) or idle (kept for later). Every edit can be
// undone and redone.
#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sim/rigid_transform.h"

namespace handson {

enum class HandleStatus : std::uint8_t { Active, Fixed, Idle };
const char* handleStatusName(HandleStatus s);
bool parseHandleStatus(const std::string& s, HandleStatus& out);

/// A handle's seed when it has none (made from a label map's file, restored from a session).
constexpr std::uint32_t kNoSeed = 0xffffffffu;

/// Voxels a new handle took from another when it was made (the last claimer wins): a difference
/// that spares part of the new handle gives them back (interaction/selection_edit.h).
struct Claim {
  int from = 0;
  std::vector<std::uint32_t> voxels;  ///< sorted
};

struct Handle {
  int id = 0;                        ///< 1..254 (0: none; 255: the live selection)
  HandleStatus status = HandleStatus::Active;
  std::vector<std::uint32_t> voxels;  ///< sorted linear indices (rest position)
  RigidTransform pose;                ///< cumulative rigid transform from the manipulation (R_m, t_m)
  std::uint32_t seed = kNoSeed;       ///< the voxel its selection grew from (a pinch's seed, a tapped voxel)
  std::vector<Claim> claims;          ///< what it took from other handles when made
};

class HandleSet {
 public:
  static constexpr int kLiveSelectionId = 255;
  static constexpr int kMaxHandles = 254;

  /// A new active handle from voxels (claimed from any other handle). Returns its id, or 0 if
  /// refused (no voxels, or no free id).
  int add(std::vector<std::uint32_t> voxels, std::uint32_t seed = kNoSeed);
  bool remove(int id);
  /// Removes b and gives what it still holds of its claims back to the handles it took them from.
  bool release(int b);
  bool setStatus(int id, HandleStatus s);
  /// a := a ∪ b, b removed. False if either is missing or a == b.
  bool unite(int a, int b);
  /// a := a ∪ (part ∩ b), b removed; what b claimed from other handles and is not in `part` (sorted)
  /// goes back to them. False as unite.
  bool unite(int a, int b, const std::vector<std::uint32_t>& part);
  /// a := a \ b (b unchanged). False if either is missing, a == b, or nothing would remain of a.
  bool subtract(int a, int b);
  /// a := (a as it was before b claimed from it) \ (cut ∩ b), b := b \ a: a difference that takes
  /// only `cut` (sorted) of b's voxels and gives a back the rest of what b took from it. The same
  /// refusals as subtract.
  bool subtract(int a, int b, const std::vector<std::uint32_t>& cut);
  /// a's voxels before b claimed some of them (sorted): a's own and b's claim on a.
  std::vector<std::uint32_t> voxelsBeforeClaim(int a, int b) const;
  /// Sets a handle's pose; `undoable` makes it an undo step (once per gesture, not per event).
  bool setPose(int id, const RigidTransform& pose, bool undoable);
  bool undo();
  bool redo();
  /// Edits recorded so far (each edit one undo step): squashSince(editCount() before some edits)
  /// makes them one undo step.
  std::uint64_t editCount() const { return edits_; }
  void squashSince(std::uint64_t count);
  /// Takes back the last edit without a redo step (an edit its caller refuses once made), the undo
  /// and redo history as they were before it.
  bool revert();
  bool canUndo() const { return !undo_.empty(); }
  bool canRedo() const { return !redo_.empty(); }

  const std::vector<Handle>& handles() const { return handles_; }
  const Handle* find(int id) const;
  /// Tint per id for the raymarch (gpu::kMaxHandleIds entries): active warm, fixed blue, idle grey,
  /// the live selection bright green; `highlight` (a picked handle) is drawn stronger.
  std::vector<glm::vec4> tints(int highlight = 0) const;
  /// What a mask of handle ids needs to go from `before` to `after` (handles matched by id): the
  /// voxels that left a handle, cleared first, then those that joined one, set to its id. Linear in
  /// the handles' voxels (sorted merges), for partial mask uploads.
  struct MaskChange {
    std::vector<std::uint32_t> cleared;
    std::vector<std::pair<std::uint32_t, std::uint8_t>> joined;
  };
  static MaskChange maskChange(const std::vector<Handle>& before, const std::vector<Handle>& after);

  HandleSet() = default;
  /// A set holding these handles, with no history (a copy to edit off the frame's thread).
  explicit HandleSet(std::vector<Handle> handles) : handles_(std::move(handles)) {}
  /// Every handle replaced by `after` (an edit made on a copy, interaction/selection_edit.h): one
  /// undo step.
  void replace(std::vector<Handle> after);

 private:
  /// The state before an edit into the undo history (`move`: taken, the caller sets the new one).
  void snapshot(bool move = false);
  Handle* get(int id);
  /// Erases the handles that match `gone` and every claim on them (their ids may be reused).
  template <class Pred> void erase(Pred gone);
  std::vector<Handle> handles_;
  std::vector<std::vector<Handle>> undo_, redo_;
  std::uint64_t edits_ = 0;
  // What the last snapshot cleared or trimmed, for revert().
  std::vector<std::vector<Handle>> clearedRedo_;
  std::optional<std::vector<Handle>> trimmed_;
};

}  // namespace handson
