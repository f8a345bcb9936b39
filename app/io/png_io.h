#pragma once
// PNG output for frames and charts (libpng). Writes atomically: a temporary file renamed into place.
#include <cstdint>
#include <string>
#include <vector>

namespace handson {

/// rgba: width*height*4 bytes, row 0 at the top. Throws handson::Error on failure.
void writePng(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgba);
/// Reads an 8-bit RGB or RGBA PNG back as RGBA (for tests and golden-image comparisons).
std::vector<std::uint8_t> readPng(const std::string& path, int& width, int& height);

}  // namespace handson
