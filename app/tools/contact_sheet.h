#pragma once
// A contact sheet: frames of a replay tiled into one PNG a person can open at once (the headless
// main job's overview of the session it played).
#include <string>
#include <vector>

namespace handson {

/// Tiles up to `tiles` of the given frames (RGBA PNGs of one size), evenly spaced from the first to
/// the last, `columns` a row, with a 4-pixel dark gutter, into `out`. Each tile is the part of its
/// frame that holds the frames' content (every pixel unlike the background, the top-left pixel,
/// in any of them, plus a margin), box-filtered down to at most `tileWidth` pixels wide. Throws handson::Error on no frames, unreadable frames or frames
/// of different sizes.
void writeContactSheet(const std::vector<std::string>& frames, const std::string& out, int tiles = 12, int columns = 4, int tileWidth = 256);

}  // namespace handson
