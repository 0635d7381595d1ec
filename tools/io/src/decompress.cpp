// Reads a whole file into memory, inflating .gz (zlib) and .xz (liblzma) by suffix.
#include <lzma.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <string_view>

#include "irgrid/error.h"
#include "irgrid/io/scene.h"

namespace irgrid {
namespace {

bool ends_with_ignoring_case(const std::string& text, const std::string& suffix) {
  if (text.size() < suffix.size()) return false;
  return std::equal(suffix.rbegin(), suffix.rend(), text.rbegin(), [](char a, char b) {
    return std::tolower(static_cast<unsigned char>(a)) ==
           std::tolower(static_cast<unsigned char>(b));
  });
}

[[noreturn]] void throw_io(const std::string& path, const std::string& what) {
  throw Error(ErrorCode::io, path + ": " + what);
}

struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};

std::string read_raw_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw_io(path, "cannot open: is a directory");
  // A device or a pipe may never end (/dev/zero read forever); scenes are regular files.
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw_io(path, "cannot read: not a regular file (a device, pipe or socket)");
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file) throw_io(path, std::string("cannot open: ") + std::strerror(errno));
  const auto size = std::filesystem::file_size(path, ec);
  std::string data;
  // The size is only a hint (the file may change under us); read until EOF regardless.
  data.resize(ec ? std::size_t(1) << 16 : std::size_t(size) + 1);
  std::size_t used = 0;
  for (;;) {
    if (used == data.size()) data.resize(data.size() * 2);
    const std::size_t got = std::fread(data.data() + used, 1, data.size() - used, file.get());
    used += got;
    if (got == 0) break;
  }
  if (std::ferror(file.get())) throw_io(path, std::string("read error: ") + std::strerror(errno));
  data.resize(used);
  return data;
}

/// The most a compressed file of `compressed` bytes may inflate to: 64 times its size (the
/// shared scenes inflate 2 to 17 times), at least 256 MiB, at most 64 GiB. A 3 MB gzip of
/// newlines once inflated to 3 GB and took 6 GB of memory.
std::size_t inflate_limit(std::size_t compressed) {
  constexpr std::size_t kFloor = std::size_t(256) << 20, kCeiling = std::size_t(64) << 30;
  return std::min(kCeiling,
                  std::max(kFloor, compressed > kCeiling / 64 ? kCeiling : 64 * compressed));
}

[[noreturn]] void throw_bomb(const std::string& path, std::size_t compressed) {
  throw Error(ErrorCode::limit_exceeded,
              path + ": inflates to more than " + std::to_string(inflate_limit(compressed) >> 20) +
                  " MiB (64 times its " + std::to_string(compressed) +
                  " bytes, at least 256 MiB): refused as a likely decompression bomb; "
                  "decompress it yourself if it is a real scene");
}

// Grows `out` when the decoder filled it, up to `limit` bytes (then one byte more, so that
// passing the limit shows); returns the free space.
std::size_t make_room(std::string& out, std::size_t used, std::size_t limit) {
  if (used == out.size())
    out.resize(std::min(std::max<std::size_t>(out.size() * 2, 1 << 16), limit + 1));
  return out.size() - used;
}

// zlib counts in uInt; feed it at most this much at a time.
constexpr std::size_t kZlibChunk = std::size_t(1) << 30;

// Inflates one gzip member starting at `offset`; returns the offset after it.
std::size_t inflate_gzip_member(const std::string& path, const std::string& in, std::size_t offset,
                                std::string& out, std::size_t& used) {
  z_stream z{};
  if (inflateInit2(&z, 16 + MAX_WBITS) != Z_OK) throw_io(path, "cannot initialise zlib");
  int rc = Z_OK;
  while (rc != Z_STREAM_END) {
    if (z.avail_in == 0) {
      if (offset == in.size()) break;
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data() + offset));
      z.avail_in = uInt(std::min(in.size() - offset, kZlibChunk));
      offset += z.avail_in;
    }
    const std::size_t limit = inflate_limit(in.size());
    if (used > limit) {
      inflateEnd(&z);
      throw_bomb(path, in.size());
    }
    z.avail_out = uInt(std::min(make_room(out, used, limit), kZlibChunk));
    z.next_out = reinterpret_cast<Bytef*>(out.data() + used);
    const uInt before = z.avail_out;
    rc = inflate(&z, Z_NO_FLUSH);
    used += before - z.avail_out;
    if (rc != Z_OK && rc != Z_STREAM_END && rc != Z_BUF_ERROR) {
      const std::string detail = z.msg ? z.msg : zError(rc);
      inflateEnd(&z);
      throw_io(path, "corrupt gzip data (" + detail + ")");
    }
  }
  offset -= z.avail_in;
  inflateEnd(&z);
  if (rc != Z_STREAM_END) throw_io(path, "truncated gzip data");
  return offset;
}

std::string inflate_gzip(const std::string& path, const std::string& in) {
  std::string out(std::min(std::max<std::size_t>(in.size() * 4, 1 << 16), inflate_limit(in.size())),
                  '\0');
  std::size_t used = 0;
  std::size_t offset = 0;
  do {  // gzip allows several members back to back; each inflates independently.
    offset = inflate_gzip_member(path, in, offset, out, used);
  } while (offset < in.size() && in[offset] == '\x1f');
  if (offset < in.size()) throw_io(path, "trailing garbage after gzip data");
  out.resize(used);
  return out;
}

std::string lzma_message(lzma_ret rc) {
  switch (rc) {
    case LZMA_FORMAT_ERROR:
      return "not in xz format";
    case LZMA_OPTIONS_ERROR:
      return "unsupported xz options";
    case LZMA_DATA_ERROR:
      return "corrupt xz data";
    case LZMA_BUF_ERROR:
      return "truncated xz data";
    case LZMA_MEM_ERROR:
      return "out of memory decompressing xz data";
    default:
      return "xz decoder error " + std::to_string(int(rc));
  }
}

std::string decompress_xz(const std::string& path, const std::string& in) {
  lzma_stream xz = LZMA_STREAM_INIT;
  // LZMA_CONCATENATED: `xz a b > c` style files hold several streams one after another.
  lzma_ret rc =
      lzma_stream_decoder(&xz, std::numeric_limits<std::uint64_t>::max(), LZMA_CONCATENATED);
  if (rc != LZMA_OK) throw_io(path, "cannot initialise liblzma: " + lzma_message(rc));
  const std::size_t limit = inflate_limit(in.size());
  std::string out(std::min(std::max<std::size_t>(in.size() * 4, 1 << 16), limit), '\0');
  std::size_t used = 0;
  xz.next_in = reinterpret_cast<const std::uint8_t*>(in.data());
  xz.avail_in = in.size();
  while (rc == LZMA_OK) {
    if (used > limit) {
      lzma_end(&xz);
      throw_bomb(path, in.size());
    }
    xz.avail_out = make_room(out, used, limit);
    xz.next_out = reinterpret_cast<std::uint8_t*>(out.data() + used);
    const std::size_t before = xz.avail_out;
    // All input is present, so every call may finish; this also ends concatenated mode.
    rc = lzma_code(&xz, LZMA_FINISH);
    used += before - xz.avail_out;
  }
  lzma_end(&xz);
  if (rc == LZMA_MEM_ERROR) throw Error(ErrorCode::out_of_memory, path + ": " + lzma_message(rc));
  if (rc != LZMA_STREAM_END)
    throw_io(path, lzma_message(rc) + " (liblzma code " + std::to_string(int(rc)) + ")");
  out.resize(used);
  return out;
}

}  // namespace

std::string read_file_decompressed(const std::string& path) {
  std::string raw = read_raw_file(path);
  // By suffix, or by the format's magic bytes when a compressed file lost its suffix (a gzip
  // file named .obj once printed its raw bytes in the parser's message). A text scene never
  // starts with these bytes.
  if (ends_with_ignoring_case(path, ".gz") || raw.starts_with("\x1F\x8B"))
    return inflate_gzip(path, raw);
  if (ends_with_ignoring_case(path, ".xz") || raw.starts_with(std::string_view("\xFD"
                                                                               "7zXZ\0",
                                                                               6)))
    return decompress_xz(path, raw);
  return raw;
}

}  // namespace irgrid
