#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "app/tools/gesture_stress.h"
#include "sim/base/error.h"

namespace {

TEST(GestureStress, TheStreamHoldsEveryKindOfBrokenInputAndIsDeterministic) {
  // What the robustness runs rely on: 2,000 sequences hold NaN and infinite coordinates, far
  // out-of-window ones, NaN pressures, more than ten fingers down at once, lost lifts (a finger
  // down again while still down), cancels, taps during drags, mode switches while fingers are
  // down, and handle edits; times never decrease; the same seed gives the same stream.
  handson::GestureStreamOptions o;
  o.sequences = 2000;
  o.seed = 11;
  const handson::SessionScript s = handson::randomGestureStream(o);
  int nanXY = 0, infXY = 0, outside = 0, nanPressure = 0, redown = 0, cancels = 0, modeSwitchesMidGesture = 0, edits = 0;
  std::size_t maxDown = 0;
  std::set<std::int64_t> down;
  double last = 0.0;
  for (const auto& e : s.events) {
    EXPECT_GE(e.t, last);
    last = e.t;
    if (!e.isTouch) {
      if (e.action == handson::UiAction::SetMode && !down.empty()) ++modeSwitchesMidGesture;
      if (handson::isHandleEdit(e.action)) ++edits;
      continue;
    }
    const auto& p = e.touch.px;
    nanXY += std::isnan(p.x) || std::isnan(p.y);
    infXY += std::isinf(p.x) || std::isinf(p.y);
    outside += std::isfinite(p.x) && std::isfinite(p.y) && (p.x < 0 || p.y < 0 || p.x > o.viewport.width || p.y > o.viewport.height);
    nanPressure += std::isnan(e.touch.pressure);
    if (e.touch.phase == handson::TouchPhase::Down) {
      redown += !down.insert(e.touch.id).second;
    } else if (e.touch.phase == handson::TouchPhase::Up || e.touch.phase == handson::TouchPhase::Cancel) {
      cancels += e.touch.phase == handson::TouchPhase::Cancel;
      down.erase(e.touch.id);
    }
    maxDown = std::max(maxDown, down.size());
  }
  EXPECT_GT(nanXY, 100);
  EXPECT_GT(infXY, 20);
  EXPECT_GT(outside, 500);
  EXPECT_GT(nanPressure, 100);
  EXPECT_GT(redown, 10) << "lost lifts whose finger comes down again";
  EXPECT_GT(cancels, 20);
  EXPECT_GT(maxDown, 10u);
  EXPECT_GT(modeSwitchesMidGesture, 20);
  EXPECT_GT(edits, 200);
  const handson::SessionScript again = handson::randomGestureStream(o);
  ASSERT_EQ(again.events.size(), s.events.size());
  for (std::size_t i = 0; i < s.events.size(); ++i) {
    EXPECT_EQ(again.events[i].action, s.events[i].action);
    EXPECT_EQ(again.events[i].touch.id, s.events[i].touch.id);
  }
  o.sequences = -1;
  EXPECT_THROW(handson::randomGestureStream(o), handson::Error);
}

}  // namespace
