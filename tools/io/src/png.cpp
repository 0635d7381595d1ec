// PNG output through stb_image_write (Debian's libstb).
#include <fmt/format.h>
#include <stb_image_write.h>

#include "irgrid/error.h"
#include "irgrid/io/image.h"

namespace irgrid {

void write_png(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb) {
  if (width <= 0 || height <= 0 || rgb.size() != std::size_t(width) * std::size_t(height) * 3)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("write_png: {} bytes do not make a {}x{} RGB image", rgb.size(), width,
                            height));
  if (!stbi_write_png(path.c_str(), width, height, 3, rgb.data(), width * 3))
    throw Error(ErrorCode::io, fmt::format("{}: cannot write PNG", path));
}

}  // namespace irgrid
