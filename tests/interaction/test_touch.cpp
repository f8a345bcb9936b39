#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "interaction/touch.h"

using namespace handson;

namespace {
TouchEvent ev(TouchPhase p, std::int64_t id, double x, double y, double t = 0.0) {
  TouchEvent e;
  e.phase = p;
  e.id = id;
  e.px = {x, y};
  e.time = t;
  return e;
}
}  // namespace

TEST(TouchInput, TracksFingersThroughTheirLife) {
  TouchInput in;
  in.setViewport({800, 600});
  EXPECT_TRUE(in.apply(ev(TouchPhase::Down, 7, 100, 100)));
  EXPECT_TRUE(in.apply(ev(TouchPhase::Down, 9, 200, 300, 0.1)));
  EXPECT_TRUE(in.apply(ev(TouchPhase::Move, 7, 110, 120, 0.2)));
  ASSERT_EQ(in.fingers().size(), 2u);
  EXPECT_EQ(in.find(7)->px, glm::dvec2(110, 120));
  EXPECT_EQ(in.find(7)->downPx, glm::dvec2(100, 100));
  EXPECT_TRUE(in.apply(ev(TouchPhase::Up, 7, 110, 120, 0.3)));
  EXPECT_EQ(in.fingers().size(), 1u);
  EXPECT_TRUE(in.apply(ev(TouchPhase::Cancel, 9, 0, 0, 0.4)));
  EXPECT_TRUE(in.fingers().empty());
  EXPECT_EQ(in.refusedCount(), 0u);
}

TEST(TouchInput, NeverTrustsItsInput) {
  TouchInput in;
  in.setViewport({100, 100});
  std::string why;
  EXPECT_FALSE(in.apply(ev(TouchPhase::Move, 1, 5, 5), &why));
  EXPECT_NE(why.find("not down"), std::string::npos);
  EXPECT_FALSE(in.apply(ev(TouchPhase::Up, 2, 5, 5)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(in.apply(ev(TouchPhase::Down, 3, nan, 5)));
  EXPECT_FALSE(in.apply(ev(TouchPhase::Down, 3, 5, INFINITY)));
  EXPECT_FALSE(in.apply(ev(TouchPhase::Down, 3, 5, 5, nan)));
  EXPECT_TRUE(in.fingers().empty());
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(in.apply(ev(TouchPhase::Down, 100 + i, i, i)));
  EXPECT_FALSE(in.apply(ev(TouchPhase::Down, 200, 1, 1), &why));  // an eleventh finger
  EXPECT_NE(why.find("10 fingers"), std::string::npos);
  EXPECT_EQ(in.fingers().size(), 10u);
  // A repeated down moves the finger; far-away coordinates are clamped to one viewport of margin.
  EXPECT_TRUE(in.apply(ev(TouchPhase::Down, 100, 1e9, -1e9)));
  EXPECT_EQ(in.find(100)->px, glm::dvec2(200, -100));
  EXPECT_EQ(in.fingers().size(), 10u);
  EXPECT_EQ(in.refusedCount(), 6u);
  // Absurd pressure is clamped, NaN pressure taken as 1.
  TouchEvent p = ev(TouchPhase::Move, 101, 3, 3);
  p.pressure = nan;
  EXPECT_TRUE(in.apply(p));
  EXPECT_EQ(in.find(101)->pressure, 1.0);
  in.cancelAll();
  EXPECT_TRUE(in.fingers().empty());
}

TEST(Viewport, PixelsToNdc) {
  const Viewport v{200, 100};
  EXPECT_EQ(v.toNdc({0, 0}), glm::dvec2(-1, -1));
  EXPECT_EQ(v.toNdc({200, 100}), glm::dvec2(1, 1));
  EXPECT_EQ(v.toNdc({100, 50}), glm::dvec2(0, 0));
}
