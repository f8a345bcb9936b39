#pragma once
// The clip region as the camera framing sees it: a clip box and plane as half-spaces, and the camera
// that shows the volume's clipped part filling the view (interaction/camera_framing.h).
#include <vector>

#include "interaction/camera_framing.h"
#include "render/render_params.h"

namespace handson {

/// The clip's half-spaces: the box's six, the plane's one (none when nothing is clipped).
std::vector<HalfSpace> clipHalfSpaces(const ClipRegion& clip);

/// `from`'s direction framing the part of the volume the clip leaves (its vertices:
/// clippedVolumeCorners); nullopt when nothing is clipped or what is left spans less than the
/// smallest voxel spacing (nothing, a corner, an edge).
std::optional<OrbitCamera> frameClip(const OrbitCamera& from, const VolumeGeometry& geometry, const ClipRegion& clip, FramingView view);

}  // namespace handson
