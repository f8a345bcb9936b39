#pragma once
// The UI actions of a session: what the buttons, the keys and a script's {"ui": NAME} events ask
// for. One enum, one name table (ui_action.cpp): scripts are read and written by these names, the
// session's parts switch on the enum.
#include <cstdint>
#include <optional>
#include <string_view>

namespace handson {

enum class UiAction : std::uint8_t {
  None,  ///< a touch event's (no action)
  // The view.
  SetMode,       ///< navigate | select | manipulate | window | clip | ...
  SetPreset,     ///< a transfer-function preset
  SetWindow,     ///< "SCALE,SHIFT,OPACITY"
  ResetWindow,
  AutoWindow,    ///< fitted to the region under the view (the frame driver's)
  ResetCamera,
  FrameClip,     ///< the camera moved to frame the clip
  CameraBack,    ///< back to the camera before the last framing
  SetClipBox,    ///< "X0,Y0,Z0,X1,Y1,Z1" (RAS mm)
  SetClipPlane,  ///< "NX,NY,NZ,D"
  ClearClip,
  ToggleStrain,
  ToggleLimits,
  ToggleLabels,
  // The handles.
  HandleStatus,      ///< "ID:STATUS"
  HandleDelete,      ///< "ID"
  HandleUnion,       ///< "A,B"
  HandleDifference,  ///< "A,B"
  Undo,
  Redo,
  LabelHandle,  ///< a labelled organ made a handle
  PinchOp,      ///< what a finished pinch does
  ToggleLock,   ///< a manipulation lock
  // The simulation and the session.
  SetInterface,  ///< sliding | glued
  Cut,           ///< a cut's quads (interaction/cut_stroke.h, formatCutQuads), applied at once
  ClearCuts,     ///< every cut undone
  Export,
  Count
};

/// The action's script name ("set-mode"); "" for None.
const char* uiActionName(UiAction a);
/// The action named `name`; nullopt for an unknown name (and for "").
std::optional<UiAction> parseUiAction(std::string_view name);
/// An edit of the handles (status, delete, union, difference, undo, redo, a label's handle): what
/// drops a drag whose picks are not back.
bool isHandleEdit(UiAction a);
/// A whole number written in full ("12"; not "12a", "", or beyond int): a handle's id in a value.
bool parseWholeNumber(std::string_view text, int& out);

}  // namespace handson
