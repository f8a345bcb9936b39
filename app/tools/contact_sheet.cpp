#include "app/tools/contact_sheet.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include "app/io/png_io.h"
#include "sim/base/error.h"

namespace handson {

namespace {

struct Image {
  int w = 0, h = 0;
  std::vector<std::uint8_t> rgba;
  const std::uint8_t* at(int x, int y) const { return &rgba[(std::size_t(y) * std::size_t(w) + std::size_t(x)) * 4]; }
};

/// The box holding every pixel of any frame that differs from its top-left (background) pixel.
void contentBox(const std::vector<Image>& frames, int& x0, int& y0, int& x1, int& y1) {
  x0 = frames[0].w, y0 = frames[0].h, x1 = -1, y1 = -1;
  for (const Image& f : frames) {
    const std::uint8_t* bg = f.at(0, 0);
    for (int y = 0; y < f.h; ++y)
      for (int x = 0; x < f.w; ++x) {
        const std::uint8_t* p = f.at(x, y);
        if (std::abs(int(p[0]) - bg[0]) + std::abs(int(p[1]) - bg[1]) + std::abs(int(p[2]) - bg[2]) <= 6) continue;
        x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
      }
  }
  if (x1 < 0) x0 = 0, y0 = 0, x1 = frames[0].w - 1, y1 = frames[0].h - 1;  // blank frames: all of them
}

}  // namespace

void writeContactSheet(const std::vector<std::string>& paths, const std::string& out, int tiles, int columns, int tileWidth) {
  if (paths.empty()) throw Error("contact sheet: no frames");
  if (tiles < 1 || columns < 1 || tileWidth < 1) throw Error("contact sheet: tiles, columns and the tile width must be positive");
  const int n = std::min<int>(tiles, int(paths.size()));
  std::vector<Image> frames(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    // Evenly spaced from the first frame to the last.
    const std::size_t k = n == 1 ? 0 : std::size_t(double(i) * double(paths.size() - 1) / double(n - 1) + 0.5);
    Image& f = frames[std::size_t(i)];
    f.rgba = readPng(paths[k], f.w, f.h);
    if (f.w != frames[0].w || f.h != frames[0].h) throw Error("contact sheet: '" + paths[k] + "' is not the size of the first frame");
  }
  // Each tile: the frames' common content box (plus a margin), box-filtered down to the tile width.
  int x0, y0, x1, y1;
  contentBox(frames, x0, y0, x1, y1);
  const int margin = 6;
  x0 = std::max(0, x0 - margin), y0 = std::max(0, y0 - margin);
  x1 = std::min(frames[0].w - 1, x1 + margin), y1 = std::min(frames[0].h - 1, y1 + margin);
  const int cw = x1 - x0 + 1, ch = y1 - y0 + 1;
  const int factor = std::max(1, (cw + tileWidth - 1) / tileWidth);
  const int tw = std::max(1, cw / factor), th = std::max(1, ch / factor), gutter = 4;
  const int cols = std::min(columns, n), rows = (n + cols - 1) / cols;
  const int W = cols * tw + (cols + 1) * gutter, H = rows * th + (rows + 1) * gutter;
  std::vector<std::uint8_t> sheet(std::size_t(W) * std::size_t(H) * 4, 0);
  for (std::size_t p = 0; p < sheet.size(); p += 4) sheet[p] = 20, sheet[p + 1] = 22, sheet[p + 2] = 26, sheet[p + 3] = 255;
  for (int i = 0; i < n; ++i) {
    const Image& f = frames[std::size_t(i)];
    const int sx = gutter + (i % cols) * (tw + gutter), sy = gutter + (i / cols) * (th + gutter);
    for (int y = 0; y < th; ++y)
      for (int x = 0; x < tw; ++x)
        for (int c = 0; c < 4; ++c) {
          unsigned sum = 0;
          for (int dy = 0; dy < factor; ++dy)
            for (int dx = 0; dx < factor; ++dx) sum += f.at(x0 + x * factor + dx, y0 + y * factor + dy)[c];
          sheet[(std::size_t(sy + y) * std::size_t(W) + std::size_t(sx + x)) * 4 + std::size_t(c)] =
              std::uint8_t((sum + unsigned(factor * factor) / 2) / unsigned(factor * factor));
        }
  }
  writePng(out, W, H, sheet);
}

}  // namespace handson
