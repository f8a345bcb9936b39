#pragma once
// Random gesture streams for robustness runs (`handson stress-gestures`, tests): many short
// sequences of touches and UI actions of every kind the app takes, valid and not — one- to
// three-finger drags, pinches, taps (also during drags), up to 20 fingers at once, NaN and
// out-of-window coordinates, lost lifts (a finger never released, its id reused later), mode
// switches and handle edits in the middle of gestures. Played through the whole headless pipeline
// (runReplay with the script in memory: a script file cannot hold NaN; four frames a sequence), the session must neither
// crash nor leave a non-finite number in a handle, the camera or the simulated mesh.
#include <cstdint>

#include "app/session/session_script.h"

namespace handson {

struct GestureStreamOptions {
  int sequences = 1000;
  std::uint32_t seed = 1;
  Viewport viewport{96, 96};
  double secondsPerSequence = 0.1;  ///< script time per sequence (replayed at 1 / this fps: one frame each)
};

/// Deterministic for a seed. Events are sorted by time; each sequence starts at k * secondsPerSequence.
SessionScript randomGestureStream(const GestureStreamOptions& options);

}  // namespace handson
