#include "render/pass_id.h"

#include <array>
#include <cstddef>

namespace handson {

namespace {
constexpr std::array<const char*, std::size_t(PassId::Count)> kNames = {
    "",
    "brick-minmax",
    "brick-readback",
    "mask-upload",
    "live-mask-copy",
    "live-mask",
    "raymarch",
    "still-frame",
    "pick",
    "pick-readback",
    "image-readback",
    "grow-clear",
    "grow-seed",
    "grow-relax",
    "grow-resume",
    "grow-compact",
    "grow-list-reset",
    "grow-active-readback",
    "deform-interpolate",
    "deform-reset",
    "deform-bounds",
    "deform-bricks",
    "deform-args",
    "deform-clear",
    "deform-claim",
    "deform-resolve",
    "deform-box-readback",
    "deform-strain",
    "deform-strain-raster",
    "blit",
    "ui",
    "screenshot",
};
static_assert(kNames.back() != nullptr, "a name for every pass id");
}  // namespace

const char* passName(PassId id) {
  const auto i = std::size_t(id);
  return i < kNames.size() ? kNames[i] : "";
}

}  // namespace handson
