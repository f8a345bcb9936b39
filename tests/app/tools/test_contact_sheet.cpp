// The contact sheet: frames evenly spaced, cropped to the content they share, tiled exactly.
#include <gtest/gtest.h>

#include <filesystem>
#include <unistd.h>

#include "app/io/png_io.h"
#include "app/tools/contact_sheet.h"
#include "sim/base/error.h"

namespace fs = std::filesystem;

TEST(ContactSheet, TilesEvenlySpacedFramesCroppedToTheirContent) {
  const fs::path dir = fs::temp_directory_path() / ("handson_sheet_" + std::to_string(getpid()));
  fs::create_directories(dir);
  // Five 40x30 frames of a grey background with a 2x2 white square at x = 10 + 2k, y = 12: the
  // content box is x 10..19, y 12..13, plus a 6 px margin: x 4..25, y 6..19 (22 x 14).
  std::vector<std::string> paths;
  for (int k = 0; k < 5; ++k) {
    std::vector<std::uint8_t> rgba(40 * 30 * 4, 60);
    for (std::size_t p = 3; p < rgba.size(); p += 4) rgba[p] = 255;
    for (int y = 12; y < 14; ++y)
      for (int x = 10 + 2 * k; x < 12 + 2 * k; ++x)
        for (int c = 0; c < 3; ++c) rgba[(std::size_t(y) * 40 + std::size_t(x)) * 4 + std::size_t(c)] = 250;
    paths.push_back((dir / ("frame_" + std::to_string(k) + ".png")).string());
    handson::writePng(paths.back(), 40, 30, rgba);
  }
  const std::string out = (dir / "sheet.png").string();
  handson::writeContactSheet(paths, out, 3, 2, 256);  // frames 0, 2, 4; two a row
  int w = 0, h = 0;
  const auto s = handson::readPng(out, w, h);
  EXPECT_EQ(w, 2 * 22 + 3 * 4);
  EXPECT_EQ(h, 2 * 14 + 3 * 4);
  auto px = [&](int x, int y) { return s[(std::size_t(y) * std::size_t(w) + std::size_t(x)) * 4]; };
  // Tile i at (4 + (i % 2) * 26, 4 + (i / 2) * 18); frame 2k's square at crop x = 6 + 2 * (2k), y = 6.
  const int frameOf[3] = {0, 2, 4};
  for (int i = 0; i < 3; ++i) {
    const int tx = 4 + (i % 2) * 26, ty = 4 + (i / 2) * 18;
    const int sx = tx + 6 + 2 * frameOf[i];
    EXPECT_EQ(px(sx, ty + 6), 250) << i;
    EXPECT_EQ(px(sx + 1, ty + 7), 250) << i;
    EXPECT_EQ(px(sx - 1, ty + 6), 60) << i;
  }
  EXPECT_EQ(px(1, 1), 20);  // the gutter
  // Downscaled when wider than the tile width: 22 px of content into 11 (a 2x2 box filter).
  handson::writeContactSheet(paths, out, 3, 2, 11);
  handson::readPng(out, w, h);
  EXPECT_EQ(w, 2 * 11 + 3 * 4);
  EXPECT_EQ(h, 2 * 7 + 3 * 4);
  EXPECT_THROW(handson::writeContactSheet({}, out), handson::Error);
  fs::remove_all(dir);
}
