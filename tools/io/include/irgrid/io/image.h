// irgrid/io/image.h: writing 8-bit RGB images.
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace irgrid {

/// Writes a PNG of width x height RGB pixels, row-major from the top-left. Throws Error{io}
/// naming the path when it cannot be written, Error{invalid_argument} on a size mismatch.
void write_png(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb);

}  // namespace irgrid
