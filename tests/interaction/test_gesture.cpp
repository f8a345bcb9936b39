#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "interaction/gesture.h"

using namespace handson;

namespace {

TouchEvent ev(TouchPhase p, std::int64_t id, glm::dvec2 px, double t = 0.0) {
  TouchEvent e;
  e.phase = p;
  e.id = id;
  e.px = px;
  e.time = t;
  return e;
}

// Pixel position of a world point for a camera and viewport (x right, y down).
glm::dvec2 project(const OrbitCamera& c, const Viewport& vp, glm::dvec3 p) {
  const glm::dmat4 m = glm::dmat4(c.projection(double(vp.width) / vp.height)) * glm::dmat4(c.view());
  const glm::dvec4 h = m * glm::dvec4(p, 1.0);
  const glm::dvec2 ndc = glm::dvec2(h) / h.w;
  return {(ndc.x + 1.0) * 0.5 * vp.width, (ndc.y + 1.0) * 0.5 * vp.height};
}

// World point on the plane through the target (perpendicular to the view) under a pixel.
glm::dvec3 underPixel(const OrbitCamera& c, const Viewport& vp, glm::dvec2 px) {
  const double pix = c.pixelSizeAt(c.distance, vp.height);
  return c.target + c.right() * ((px.x - 0.5 * vp.width) * pix) + c.up() * ((0.5 * vp.height - px.y) * pix);
}

OrbitCamera startCamera() {
  OrbitCamera c;
  c.target = {10, -20, 5};
  c.distance = 400;
  c.azimuth = 0.3;
  c.elevation = 0.2;
  c.roll = 0.1;
  return c;
}

}  // namespace

TEST(GestureRecognizer, OneFingerOrbitsWithTheObjectFollowingTheFinger) {
  OrbitCamera cam = startCamera();
  GestureRecognizer g(cam);
  g.setViewport({600, 400});
  g.handle(ev(TouchPhase::Down, 1, {300, 200}));
  g.handle(ev(TouchPhase::Move, 1, {340, 200}));
  g.handle(ev(TouchPhase::Move, 1, {400, 250}));
  EXPECT_NEAR(cam.azimuth, 0.3 + 100 * 3.14159265358979 / 400, 1e-9);
  EXPECT_NEAR(cam.elevation, 0.2 + 50 * 3.14159265358979 / 400, 1e-9);
  EXPECT_EQ(cam.distance, 400);
  g.handle(ev(TouchPhase::Up, 1, {400, 250}));
  const double az = cam.azimuth;
  g.handle(ev(TouchPhase::Down, 2, {10, 10}));  // a new drag starts from the current camera
  g.handle(ev(TouchPhase::Move, 2, {10, 10}));
  EXPECT_EQ(cam.azimuth, az);
}

TEST(GestureRecognizer, TwoFingersKeepTargetPlanePointsUnderTheFingers) {
  // Random pinch-pan-twists: the world points that started under the fingers end under them.
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> pos(50, 550), jitter(-120, 120);
  for (int trial = 0; trial < 50; ++trial) {
    OrbitCamera cam = startCamera();
    const Viewport vp{600, 400};
    GestureRecognizer g(cam);
    g.setViewport(vp);
    const glm::dvec2 a0(pos(rng), pos(rng) * 0.6), b0(pos(rng), pos(rng) * 0.6);
    if (glm::length(a0 - b0) < 30) continue;
    const glm::dvec3 A = underPixel(cam, vp, a0), B = underPixel(cam, vp, b0);
    g.handle(ev(TouchPhase::Down, 1, a0));
    g.handle(ev(TouchPhase::Down, 2, b0));
    glm::dvec2 a = a0, b = b0;
    for (int step = 0; step < 5; ++step) {
      a += glm::dvec2(jitter(rng), jitter(rng)) * 0.2;
      b += glm::dvec2(jitter(rng), jitter(rng)) * 0.2;
      g.handle(ev(TouchPhase::Move, 1, a));
      g.handle(ev(TouchPhase::Move, 2, b));
    }
    if (glm::length(a - b) < 10) continue;
    // Exact in exact arithmetic; the camera's matrices are single precision (about 1e-7 relative,
    // i.e. ~1e-5 px here), hence 1e-3 px.
    EXPECT_LT(glm::length(project(cam, vp, A) - a), 1e-3) << "trial " << trial;
    EXPECT_LT(glm::length(project(cam, vp, B) - b), 1e-3) << "trial " << trial;
  }
}

TEST(GestureRecognizer, PinchZoomsAndTwistRolls) {
  OrbitCamera cam = startCamera();
  GestureRecognizer g(cam);
  g.setViewport({600, 400});
  g.handle(ev(TouchPhase::Down, 1, {250, 200}));
  g.handle(ev(TouchPhase::Down, 2, {350, 200}));
  g.handle(ev(TouchPhase::Move, 1, {200, 200}));
  g.handle(ev(TouchPhase::Move, 2, {400, 200}));  // spread x2: twice as close
  EXPECT_NEAR(cam.distance, 200, 1e-9);
  EXPECT_NEAR(cam.roll, 0.1, 1e-9);
  // Twist by 90 degrees clockwise on screen about the centre.
  g.handle(ev(TouchPhase::Move, 1, {300, 100}));
  g.handle(ev(TouchPhase::Move, 2, {300, 300}));
  EXPECT_NEAR(cam.roll, 0.1 - 3.14159265358979 / 2, 1e-9);
}

TEST(GestureRecognizer, ChangingFingerCountReanchorsWithoutAJump) {
  OrbitCamera cam = startCamera();
  GestureRecognizer g(cam);
  g.setViewport({600, 400});
  g.handle(ev(TouchPhase::Down, 1, {300, 200}));
  g.handle(ev(TouchPhase::Move, 1, {320, 200}));
  const OrbitCamera afterOrbit = cam;
  g.handle(ev(TouchPhase::Down, 2, {400, 250}));  // second finger lands: nothing moves
  EXPECT_EQ(cam.azimuth, afterOrbit.azimuth);
  g.handle(ev(TouchPhase::Move, 2, {400, 250}));
  EXPECT_NEAR(glm::length(cam.target - afterOrbit.target), 0.0, 1e-9);
  EXPECT_NEAR(cam.distance, afterOrbit.distance, 1e-9);
  g.handle(ev(TouchPhase::Up, 2, {400, 250}));  // lifting it: nothing moves either
  g.handle(ev(TouchPhase::Move, 1, {320, 200}));
  EXPECT_NEAR(cam.azimuth, afterOrbit.azimuth, 1e-12);
}

TEST(GestureRecognizer, DegenerateAndHostileInputKeepsTheCameraFinite) {
  OrbitCamera cam = startCamera();
  GestureRecognizer g(cam);
  g.setViewport({0, -5});  // clamped to 1x1
  g.setViewport({600, 400});
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> phase(0, 3), id(0, 12);
  std::uniform_real_distribution<double> coord(-2000, 2000);
  for (int i = 0; i < 20000; ++i) {
    TouchEvent e = ev(TouchPhase(phase(rng)), id(rng), {coord(rng), coord(rng)}, i * 0.001);
    if (i % 97 == 0) e.px.x = std::nan("");
    if (i % 1000 == 0) g.setMode(InteractionMode(i / 1000 % 3));
    g.handle(e);
    ASSERT_TRUE(std::isfinite(cam.distance) && std::isfinite(cam.azimuth) && std::isfinite(cam.elevation) && std::isfinite(cam.roll) &&
                std::isfinite(cam.target.x) && std::isfinite(cam.target.y) && std::isfinite(cam.target.z))
        << "event " << i;
    ASSERT_LE(g.input().fingers().size(), TouchInput::kMaxFingers);
  }
  // Coincident fingers: no zoom or twist from a zero-length spread.
  g.cancel();
  g.setMode(InteractionMode::Navigate);
  const double d = cam.distance;
  g.handle(ev(TouchPhase::Down, 1, {300, 200}));
  g.handle(ev(TouchPhase::Down, 2, {300, 200}));
  g.handle(ev(TouchPhase::Move, 2, {301, 200}));
  EXPECT_EQ(cam.distance, d);
}

TEST(GestureRecognizer, OtherModesForwardToTheirHandlers) {
  OrbitCamera cam = startCamera();
  GestureRecognizer g(cam);
  g.setViewport({600, 400});
  int selectCalls = 0, manipulateCalls = 0;
  g.setHandler(InteractionMode::Select, [&](const TouchEvent&, const TouchInput& in) { selectCalls += int(in.fingers().size()); });
  g.setHandler(InteractionMode::Manipulate, [&](const TouchEvent&, const TouchInput&) { ++manipulateCalls; });
  g.setMode(InteractionMode::Select);
  g.handle(ev(TouchPhase::Down, 1, {300, 200}));
  g.handle(ev(TouchPhase::Move, 1, {350, 200}));
  EXPECT_EQ(cam.azimuth, 0.3);  // no navigation in select mode
  EXPECT_EQ(selectCalls, 2);
  g.setMode(InteractionMode::Manipulate);
  g.handle(ev(TouchPhase::Move, 1, {360, 200}));
  EXPECT_EQ(manipulateCalls, 1);
  InteractionMode m;
  EXPECT_TRUE(parseMode("select", m));
  EXPECT_EQ(m, InteractionMode::Select);
  EXPECT_FALSE(parseMode("dance", m));
}

TEST(GestureRecognizer, InNavigateModeAGestureStartingOnAGrabbableSpotGoesToTheManipulateHandler) {
  OrbitCamera cam = startCamera();
  GestureRecognizer g(cam);
  g.setViewport({600, 400});
  std::vector<std::pair<TouchPhase, std::size_t>> seen;  // phase and finger count at the handler
  g.setHandler(InteractionMode::Manipulate, [&](const TouchEvent& e, const TouchInput& in) { seen.push_back({e.phase, in.fingers().size()}); });
  std::vector<glm::dvec2> asked;
  g.setGrabProbe([&](glm::dvec2 px) {
    asked.push_back(px);
    return px.x < 100;  // the left strip holds "a handle"
  });
  const OrbitCamera before = cam;
  // On the handle: two fingers come and go, nothing reaches the camera, the probe is asked once.
  g.handle(ev(TouchPhase::Down, 1, {50, 200}));
  EXPECT_TRUE(g.grabbing());
  g.handle(ev(TouchPhase::Down, 2, {300, 200}));  // a second finger joins the grab, wherever it lands
  g.handle(ev(TouchPhase::Move, 1, {80, 220}));
  g.handle(ev(TouchPhase::Move, 2, {340, 200}));
  g.handle(ev(TouchPhase::Up, 2, {340, 200}));
  g.handle(ev(TouchPhase::Move, 1, {90, 220}));
  g.handle(ev(TouchPhase::Up, 1, {90, 220}));
  EXPECT_FALSE(g.grabbing());
  EXPECT_EQ(asked.size(), 1u);
  ASSERT_EQ(seen.size(), 7u);
  EXPECT_EQ(seen[1].second, 2u);
  EXPECT_EQ(seen.back().first, TouchPhase::Up);
  EXPECT_EQ(cam.azimuth, before.azimuth);
  EXPECT_EQ(cam.elevation, before.elevation);
  // Off the handle: the drag orbits and the handler hears nothing.
  seen.clear();
  g.handle(ev(TouchPhase::Down, 3, {300, 200}));
  g.handle(ev(TouchPhase::Move, 3, {340, 200}));
  EXPECT_FALSE(g.grabbing());
  EXPECT_TRUE(seen.empty());
  EXPECT_NEAR(cam.azimuth, before.azimuth + 40 * 3.14159265358979 / 400, 1e-9);
  g.handle(ev(TouchPhase::Up, 3, {340, 200}));
  // A grab cut short (focus lost) lets go with a cancel; other modes never ask the probe.
  g.handle(ev(TouchPhase::Down, 4, {20, 20}));
  g.cancel();
  EXPECT_FALSE(g.grabbing());
  EXPECT_EQ(seen.back().first, TouchPhase::Cancel);
  g.setMode(InteractionMode::Select);
  g.handle(ev(TouchPhase::Down, 5, {20, 20}));
  EXPECT_EQ(asked.size(), 3u);  // asked at the first touch-downs of the three navigate gestures only
  EXPECT_FALSE(g.grabbing());
}
