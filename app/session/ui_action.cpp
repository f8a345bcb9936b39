#include "app/session/ui_action.h"

#include <array>
#include <charconv>
#include <cstddef>

namespace handson {

namespace {
constexpr std::array<const char*, std::size_t(UiAction::Count)> kNames = {
    "",
    "set-mode",
    "set-preset",
    "set-window",
    "reset-window",
    "auto-window",
    "reset-camera",
    "frame-clip",
    "camera-back",
    "set-clip-box",
    "set-clip-plane",
    "clear-clip",
    "toggle-strain",
    "toggle-limits",
    "toggle-labels",
    "handle-status",
    "handle-delete",
    "handle-union",
    "handle-difference",
    "undo",
    "redo",
    "label-handle",
    "pinch-op",
    "toggle-lock",
    "set-interface",
    "cut",
    "clear-cuts",
    "export",
};
static_assert(kNames.back() != nullptr, "a name for every action");
}  // namespace

const char* uiActionName(UiAction a) {
  const auto i = std::size_t(a);
  return i < kNames.size() ? kNames[i] : "";
}

std::optional<UiAction> parseUiAction(std::string_view name) {
  for (std::size_t i = 1; i < kNames.size(); ++i)
    if (name == kNames[i]) return UiAction(i);
  return std::nullopt;
}

bool isHandleEdit(UiAction a) {
  switch (a) {
    case UiAction::HandleStatus:
    case UiAction::HandleDelete:
    case UiAction::HandleUnion:
    case UiAction::HandleDifference:
    case UiAction::Undo:
    case UiAction::Redo:
    case UiAction::LabelHandle: return true;
    default: return false;
  }
}

bool parseWholeNumber(std::string_view text, int& out) {
  const char* end = text.data() + text.size();
  const auto r = std::from_chars(text.data(), end, out);
  return !text.empty() && r.ec == std::errc() && r.ptr == end;
}

}  // namespace handson
