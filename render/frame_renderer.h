#pragma once
// What a session's frames need of a renderer (app/session/frame_driver.h): the transfer function
// set, a frame submitted, and whether that frame shows a still picture's sum. VolumeRenderer is the
// one the app runs; the frame sequence's tests put a recording one in its place.
#include <cstdint>

namespace handson {

struct FrameRequest;
struct TfTable;

class FrameRenderer {
 public:
  virtual ~FrameRenderer() = default;
  virtual void setTransferFunction(const TfTable& lut) = 0;
  /// Records and submits one frame; its sequence number (increasing from 1).
  virtual std::uint64_t submit(const FrameRequest& request) = 0;
  /// The jitter phases in the still frame's sum the last submitted frame shows (0: not a sum).
  virtual int stillPhasesShown() const = 0;
};

}  // namespace handson
