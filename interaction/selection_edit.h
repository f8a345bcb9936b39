#pragma once
// Corrections of a selection (docs/selection-corrections.md): a pinch subtracted from a handle
// takes away what leaked into it, not the organ it leaked from; a pinch united with it adds the
// structure it was placed on, not what it leaked into.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "interaction/handles.h"
#include "sim/volume.h"

namespace handson {

/// How a correction pinch b edits a handle a.
///  - Neck (default): a difference a := a \ b takes only b's voxels on b's side of a's narrowest
///    neck between a's seed and b's; a union a := a ∪ b adds only b's lobe where b's seed lies,
///    split from b's widest lobe at b's narrowest neck (splitAtNeck); what b claimed from other
///    handles and does not keep goes back to them;
///  - Grown (the earlier rule): all of b's voxels - b's pinch grows as freely as a first one, so a
///    removal grows back into the organ where the leak has its intensity and takes it too, and an
///    addition on a thin branch grows into the tissue around it.
enum class CorrectionRule : std::uint8_t { Neck, Grown };
const char* correctionRuleName(CorrectionRule r);
bool parseCorrectionRule(const std::string& s, CorrectionRule& out);

/// A region split between two markers at its narrowest neck.
struct NeckSplit {
  std::vector<std::uint32_t> cutSide;  ///< the region's voxels on the cut marker's side (ascending)
  double keepWidthMm = 0.0, cutWidthMm = 0.0;  ///< the distance transform at the two markers (keep's after its climb)
  double neckWidthMm = 0.0;  ///< the widest path's narrowest point between them (0: not joined)
};

/// Splits `region` (ascending linear indices on g) between the markers `keep` and `cut` (voxels of
/// it) by a seeded watershed of its exact Euclidean distance transform D (mm, to the nearest voxel
/// outside it). The keep marker first climbs D (26 neighbours, to the largest while it grows) to
/// the top of its lobe: a handle's seed may lie anywhere in its organ. The cut marker stays: a
/// pinch's seed marks the leak, and a seed on the flank of the organ's own lobe then takes only
/// what lies below it there. Each voxel goes to the marker it joins by the path (6-connected,
/// inside the region) whose narrowest point is widest, equal widths (D quantized to 1/16 of the
/// smallest spacing) to the flood that reached them first (keep's before cut's): deterministic.
/// The neck is the width at which the two floods meet. `keep` kNoSeed: the region's deepest voxel.
/// Empty when a marker is not in the region or the keep marker climbs onto the cut marker. `climbCut`: the cut marker climbs too (to the
/// top of its own lobe; empty when that is the keep marker's).
NeckSplit splitAtNeck(const std::vector<std::uint32_t>& region, std::uint32_t keep, std::uint32_t cut, const VolumeGeometry& g, bool climbCut = false);

/// a := a \ b under `rule` (one undo step). With Neck the split is of a as it was before b claimed
/// from it (the region), between a's seed (the region's deepest voxel when a has none, or it is no
/// longer a's) and b's (b's voxel of the region nearest to it when b's seed lies outside; b's
/// deepest there when it has none); a keeps the rest of what b claimed. Refused (false, nothing
/// changed) as HandleSet::subtract, and with Neck when none of b lies on b's side; b touching none
/// of a: as Grown.
bool subtractHandle(HandleSet& handles, int a, int b, CorrectionRule rule, const VolumeGeometry& g);

/// What a finished pinch does to the handles (UI action "pinch-op new|add|remove", the Select
/// mode's New / Add / Remove): a new handle, or a correction of a target handle.
enum class PinchOp : std::uint8_t { New, Add, Remove };
const char* pinchOpName(PinchOp op);
bool parsePinchOp(const std::string& s, PinchOp& out);

/// What applyPinch did.
struct PinchEdit {
  int handle = 0;       ///< the handle made or corrected (0: refused)
  std::string refusal;  ///< why it was refused ("" if it was not)
};

/// What a finished pinch is to do: its op, the handle a correction edits, and the rule.
struct PinchRequest {
  PinchOp op = PinchOp::New;
  int target = 0;
  CorrectionRule rule = CorrectionRule::Neck;
};

/// Applies a finished pinch (its voxels and seed) to the handles: with New, or a target that does
/// not exist, a new handle; with Add or Remove a correction of the target - the pinch made a handle
/// (claiming its voxels), then uniteHandle, or subtractHandle and the pinch's handle released - as
/// one undo step. A refused correction leaves the handles as they were, with no redo step.
PinchEdit applyPinch(HandleSet& handles, std::vector<std::uint32_t> voxels, std::uint32_t seed, const PinchRequest& request, const VolumeGeometry& g);

/// A handle edit made on a copy of the handles, so that it can run off the frame's thread
/// (app/session/selection_controller.h), then be taken into the set it was copied from with
/// HandleSet::replace: the same handles as the edit made on that set.
struct EditOnCopy {
  bool changed = false;         ///< false: refused, nothing to take in
  std::string refusal;          ///< a refused pinch's reason (PinchEdit::refusal)
  int handle = 0;               ///< a pinch's handle (PinchEdit::handle)
  std::vector<Handle> after;    ///< the handles once edited (when changed)
  HandleSet::MaskChange mask;   ///< from the copy to `after`
  /// The box (voxel indices, inclusive) of the mask's change and of a pinch's voxels: where the
  /// shown ids may change when the edit is taken in (empty when boxMin > boxMax).
  Eigen::Vector3i boxMin = Eigen::Vector3i::Constant(std::numeric_limits<int>::max());
  Eigen::Vector3i boxMax = Eigen::Vector3i::Constant(-1);
};
/// applyPinch on a copy of the handles.
EditOnCopy applyPinchOnCopy(std::vector<Handle> handles, std::vector<std::uint32_t> voxels, std::uint32_t seed, const PinchRequest& request,
                            const VolumeGeometry& g);
/// uniteHandle (`unite`) or subtractHandle on a copy of the handles.
EditOnCopy correctOnCopy(std::vector<Handle> handles, int a, int b, bool unite, CorrectionRule rule, const VolumeGeometry& g);

/// a := a ∪ b under `rule` (one undo step; b removed; refusals as HandleSet::unite). With Neck only
/// b's voxels on its seed's side of b's narrowest neck between the top its seed climbs to and b's
/// deepest voxel (all of b when they are the same lobe, or b's seed lies outside it or it has none).
bool uniteHandle(HandleSet& handles, int a, int b, CorrectionRule rule, const VolumeGeometry& g);

}  // namespace handson
