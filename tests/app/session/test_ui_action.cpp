#include "app/session/ui_action.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace handson {
namespace {

TEST(UiAction, EveryActionHasOneNameThatReadsBackAsIt) {
  // Scripts are written and read by these names: each is its own and parses to its action.
  std::set<std::string> names;
  for (int i = 1; i < int(UiAction::Count); ++i) {
    const UiAction a = UiAction(i);
    const std::string n = uiActionName(a);
    EXPECT_FALSE(n.empty()) << i;
    EXPECT_TRUE(names.insert(n).second) << n;
    EXPECT_EQ(parseUiAction(n), a) << n;
  }
  EXPECT_EQ(parseUiAction(""), std::nullopt);
  EXPECT_EQ(parseUiAction("explode"), std::nullopt);
  EXPECT_EQ(parseUiAction("Undo"), std::nullopt) << "names are exact";
  EXPECT_EQ(parseUiAction("set-mode"), UiAction::SetMode);
}

TEST(UiAction, HandleEditsAreTheEditsOfTheHandles) {
  for (UiAction a : {UiAction::HandleStatus, UiAction::HandleDelete, UiAction::HandleUnion, UiAction::HandleDifference, UiAction::Undo, UiAction::Redo,
                     UiAction::LabelHandle})
    EXPECT_TRUE(isHandleEdit(a)) << uiActionName(a);
  for (UiAction a : {UiAction::SetMode, UiAction::ToggleStrain, UiAction::PinchOp, UiAction::ToggleLock, UiAction::Export, UiAction::None})
    EXPECT_FALSE(isHandleEdit(a)) << uiActionName(a);
}

TEST(UiAction, AHandleIdIsAWholeNumberWrittenInFull) {
  int v = -1;
  EXPECT_TRUE(parseWholeNumber("12", v));
  EXPECT_EQ(v, 12);
  EXPECT_TRUE(parseWholeNumber("-3", v));
  EXPECT_EQ(v, -3);
  for (const char* bad : {"", "12a", " 12", "1.5", "99999999999", "x"}) EXPECT_FALSE(parseWholeNumber(bad, v)) << bad;
}

}  // namespace
}  // namespace handson
