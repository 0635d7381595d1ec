// Ray and hit files: irgrid's 32-byte rays, the reference code's 24-byte rays, 16-byte hits.
// All records are little-endian float32/uint32, written and read as raw arrays.
#include <bit>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "irgrid/error.h"
#include "irgrid/io/output_file.h"
#include "irgrid/io/rays.h"

static_assert(std::endian::native == std::endian::little,
              "ray files are little endian; add byte swapping for this platform");

namespace irgrid {
namespace {

/// One record of the paper's reference code (hagrid): origin and direction only.
struct HagridRay {
  float org[3];  ///< 12 B
  float dir[3];  ///< 12 B
};
static_assert(sizeof(HagridRay) == 24);

void write_bytes(const std::string& path, const void* data, std::size_t bytes) {
  write_file_whole(path, std::string_view(static_cast<const char*>(data), bytes));
}

template <typename Record>
std::vector<Record> read_records(const std::string& path, const char* format_name) {
  std::error_code ec;
  // A directory "opens" and reports a size of 2^63 - 1; a device or pipe has no size.
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw Error(ErrorCode::io, fmt::format("{}: cannot read rays: not a regular file", path));
  std::ifstream file(path, std::ios::binary | std::ios::ate);
  if (!file)
    throw Error(ErrorCode::io, fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  const auto bytes = std::uint64_t(file.tellg());
  if (bytes % sizeof(Record) != 0)
    throw Error(ErrorCode::io,
                fmt::format("{}: {} bytes is not a whole number of {}-byte {} records", path, bytes,
                            sizeof(Record), format_name));
  if (bytes / sizeof(Record) > 0xFFFFFFFFull)
    throw Error(ErrorCode::limit_exceeded,
                fmt::format("{}: {} rays exceed 2^32 - 1", path, bytes / sizeof(Record)));
  std::vector<Record> records(bytes / sizeof(Record));
  file.seekg(0);
  if (!file.read(reinterpret_cast<char*>(records.data()), std::streamsize(bytes)))
    throw Error(ErrorCode::io, fmt::format("{}: read failed", path));
  return records;
}

}  // namespace

RayFormat parse_ray_format(const std::string& name) {
  if (name == "irgrid") return RayFormat::irgrid;
  if (name == "hagrid") return RayFormat::hagrid;
  throw Error(ErrorCode::invalid_argument,
              fmt::format("unknown ray format '{}' (expected irgrid or hagrid)", name));
}

void write_rays(const std::string& path, std::span<const Ray> rays, RayFormat format) {
  if (format == RayFormat::irgrid) return write_bytes(path, rays.data(), rays.size_bytes());
  std::vector<HagridRay> records(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i) {
    std::memcpy(records[i].org, rays[i].org, sizeof(records[i].org));
    std::memcpy(records[i].dir, rays[i].dir, sizeof(records[i].dir));
  }
  write_bytes(path, records.data(), records.size() * sizeof(HagridRay));
}

std::vector<Ray> read_rays(const std::string& path, RayFormat format, float tmin, float tmax) {
  if (format == RayFormat::irgrid) return read_records<Ray>(path, "irgrid ray");
  const auto records = read_records<HagridRay>(path, "hagrid ray");
  std::vector<Ray> rays(records.size());
  for (std::size_t i = 0; i < rays.size(); ++i) {
    std::memcpy(rays[i].org, records[i].org, sizeof(rays[i].org));
    std::memcpy(rays[i].dir, records[i].dir, sizeof(rays[i].dir));
    rays[i].tmin = tmin;
    rays[i].tmax = tmax;
  }
  return rays;
}

void write_hits(const std::string& path, std::span<const Hit> hits) {
  write_bytes(path, hits.data(), hits.size_bytes());
}

}  // namespace irgrid
