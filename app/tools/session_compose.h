#pragma once
// Composes the whole touch workflow of a hands-on session for any labelled volume: the steps of
// assets/gestures/full-session.json (made by hand for the phantom), with every touch placed on the
// anatomy that volume shows. A script of fixed screen positions fits only the anatomy it was made
// on; this one is laid out from the label map and CPU depth picks (app/tools/scenario_retarget.h):
//
//  1. The view: for directions every 30 degrees in azimuth at elevation 0 and +-25 (ties: the first),
//     the camera looks at the organ's deepest voxel from a distance that shows the organ about a fifth
//     of the viewport high (never from inside the volume); the CT's own transfer-function preset.
//     When no direction shows the organ (and the anchor) with room for the fingers, the view cuts in
//     front of it instead: the "ct-soft-tissue" preset on a CT whose preset was not chosen, and per
//     direction a view-oriented clip plane 1.5 voxels in front of the organ's nearest voxel (or of
//     the nearer of organ and anchor); the script then switches to that preset and, in Clip mode,
//     drags the plane there with one finger (the app's own gesture, interaction/view_adjust.h).
//     Every 4th pixel is depth-picked; a label's footprint is the pixels whose pick lands on it, and
//     its inscribed radius (Euclidean distance transform) says how much room the fingers have there.
//     The directions with both at least 16 and 6 px are tried roomiest first (largest organ + anchor
//     radii), up to six, until one takes the whole session (a later phase can find no room on a
//     view that shows the organ: an unstable tilt, a drag behind a neighbour). An organ whose
//     inscribed radius is under 28 px there is approached until it is (the eye outside the volume).
//  2. The chosen view is picked again every 2nd pixel; the organ's and the anchor's touches go to
//     their footprints' innermost pixels, sized by the inscribed radii (all touch-downs at least
//     3 px inside the footprint).
//  3. The events: start 30 degrees of azimuth away and orbit there with one finger (navigate); in
//     select mode pinch the organ (handle 1, active) and the anchor (handle 2, fixed), each pinch
//     spread to an extent of 2.5 inscribed radii. Each pinch is also run here through the app's own
//     PinchSelection answered by CPU picks, and the later touches go where that selection (not just
//     the label) shows; each manipulation is run here too, on the rigid model the app draws while
//     dragging (its HandleManipulator, CPU picks with the handle drawn at its pose), so that every
//     touch lands on the handle where it then is. In manipulate mode: tilt it with three fingers at
//     rest (two hold an axis, the third is drawn 0.36 of the arm toward them); drag it 20 mm with one
//     finger (of eight directions, starting away from the anchor, the one that keeps most of it in
//     sight) and 16 mm across with two (oriented where the picked depths differ least, so that the
//     parallel drag does not read as depth); twist two fingers 20 degrees (a turn about the view
//     axis) and spread two by 6 % (depth: toward the viewer); set the anchor idle; tap the organ where it shows most
//     (picked); union, undo, redo, undo, difference, undo; orbit from where the view is emptiest;
//     reset the view; export.
#include <cstdint>
#include <string>
#include <vector>

#include "app/session/session_script.h"
#include "sim/volume.h"

namespace handson {

struct ComposeOptions {
  int organ = 0;            ///< label of the organ that is selected and moved
  int anchor = 0;           ///< label of the structure fixed and pulled against
  Viewport viewport{512, 512};
  std::string preset;       ///< transfer-function preset; "" : the volume's default
  double dragMm = 20.0;     ///< one-finger drag, away from the anchor
  double pushMm = 16.0;     ///< two-finger drag, across
};

struct ComposedSession {
  SessionScript script;
  double azimuthDeg = 0.0, elevationDeg = 0.0;  ///< the view the manipulation happens in
  double mmPerPx = 0.0;                         ///< at the organ's picked surface
  glm::dvec2 organPx{0.0}, anchorPx{0.0};       ///< innermost footprint pixels
  double organRadiusPx = 0.0, anchorRadiusPx = 0.0;
  double handleRadiusPx = 0.0;                  ///< room on the organ's handle (its selection)
  std::string clipPlane;                        ///< the cut that exposes the organ ("NX,NY,NZ,D"; "" : none)
  std::string preset;                           ///< the preset the organ is handled under
};

/// Exact Euclidean distance (in cells) from each cell of an nx x ny mask to the nearest cell outside
/// it (cells beyond the border count as outside; 0 for outside cells). Throws on a size mismatch.
std::vector<double> distanceToOutside2d(const std::vector<std::uint8_t>& inside, int nx, int ny);

/// `labels` on the CT's grid. `volumePath`: what the script names as its volume ("" : the phantom).
/// Throws Error when a label is absent, the grids differ, or no direction shows both the organ and
/// the anchor with room for the fingers.
ComposedSession composeFullSession(const Volume& ct, const Volume& labels, const ComposeOptions& options, const std::string& volumePath);

}  // namespace handson
