// PNG output through stb_image_write (Debian's libstb).
#include <fmt/format.h>
#include <stb_image_write.h>

#include <string>

#include "irgrid/error.h"
#include "irgrid/io/image.h"
#include "irgrid/io/output_file.h"

namespace irgrid {

void write_png(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb) {
  if (width <= 0 || height <= 0 || rgb.size() != std::size_t(width) * std::size_t(height) * 3)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("write_png: {} bytes do not make a {}x{} RGB image", rgb.size(), width,
                            height));
  // Encoded in memory, then written whole: a full disk leaves no truncated image behind.
  std::string encoded;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), std::size_t(size));
  };
  if (!stbi_write_png_to_func(append, &encoded, width, height, 3, rgb.data(), width * 3))
    throw Error(ErrorCode::io, fmt::format("{}: cannot encode the PNG", path));
  write_file_whole(path, encoded);
}

}  // namespace irgrid
