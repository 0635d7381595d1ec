// Hostile files: legal OBJ the loader once misread, decompression bombs, devices and
// directories where files belong, and outputs written whole (docs/robustness.md).
#include <gtest/gtest.h>
#include <lzma.h>
#include <zlib.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "irgrid/error.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/output_file.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/scene.h"

namespace irgrid {
namespace {

namespace fs = std::filesystem;

class HostileInput : public ::testing::Test {
 protected:
  HostileInput() {
    std::random_device random;
    dir_ = fs::temp_directory_path() / ("irgrid-hostile-" + std::to_string(random()));
    fs::create_directories(dir_);
  }
  ~HostileInput() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  std::string write(const std::string& name, const std::string& bytes) const {
    const fs::path file = dir_ / name;
    std::ofstream(file, std::ios::binary) << bytes;
    return file.string();
  }
  /// The message of the Error that `f` throws ("" and a failure when none).
  template <typename F>
  static std::string error_of(F&& f, ErrorCode expected) {
    try {
      f();
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), expected) << e.what();
      return e.what();
    }
    ADD_FAILURE() << "no error";
    return "";
  }
  fs::path dir_;
};

void expect_unit_triangle(const Scene& scene) {
  ASSERT_EQ(scene.vertices.size(), 3u);
  ASSERT_EQ(scene.triangles.size(), 1u);
  EXPECT_EQ(scene.triangles[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
  EXPECT_EQ(scene.vertices[0][0], 0.f);
  EXPECT_EQ(scene.vertices[1][0], 1.f);
  EXPECT_EQ(scene.vertices[2][1], 1.f);
}

TEST_F(HostileInput, AByteOrderMarkKeepsTheFirstVertex) {
  expect_unit_triangle(
      load_scene(write("bom.obj", "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")));
}

TEST_F(HostileInput, TrailingCommentsAndContinuationsAreLegalObj) {
  expect_unit_triangle(load_scene(
      write("legal.obj",
            "# header\nv 0 0 0 # origin\nv 1 \\\n 0 0\nv 0 1 0\r\nf 1 2 \\\r\n 3 # face\n"
            "# a comment ending in a backslash \\\n")));
}

TEST_F(HostileInput, BinaryBytesInAMalformedLineAreEscapedInTheMessage) {
  const std::string message =
      error_of([&] { load_scene(write("junk.obj", std::string("v \x01\x02\xff 0 0\n", 11))); },
               ErrorCode::io);
  EXPECT_NE(message.find("\\x01\\x02\\xff"), std::string::npos) << message;
  for (char c : message)
    EXPECT_TRUE(static_cast<unsigned char>(c) >= 0x20 && static_cast<unsigned char>(c) < 0x7F);
}

/// Streams `repeats` copies of `block` through a gzip (level 1) encoder.
std::string gzip_repeated(const std::string& block, int repeats) {
  z_stream z{};
  EXPECT_EQ(deflateInit2(&z, 1, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out, buffer(1 << 16, '\0');
  for (int i = 0; i <= repeats; ++i) {
    const bool last = i == repeats;
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(block.data()));
    z.avail_in = last ? 0 : uInt(block.size());
    do {
      z.next_out = reinterpret_cast<Bytef*>(buffer.data());
      z.avail_out = uInt(buffer.size());
      deflate(&z, last ? Z_FINISH : Z_NO_FLUSH);
      out.append(buffer.data(), buffer.size() - z.avail_out);
    } while (z.avail_out == 0);
  }
  deflateEnd(&z);
  return out;
}

std::string xz_repeated(const std::string& block, int repeats) {
  lzma_stream s = LZMA_STREAM_INIT;
  EXPECT_EQ(lzma_easy_encoder(&s, 0, LZMA_CHECK_CRC32), LZMA_OK);
  std::string out, buffer(1 << 16, '\0');
  for (int i = 0; i <= repeats; ++i) {
    const bool last = i == repeats;
    s.next_in = reinterpret_cast<const std::uint8_t*>(block.data());
    s.avail_in = last ? 0 : block.size();
    lzma_ret rc = LZMA_OK;
    do {
      s.next_out = reinterpret_cast<std::uint8_t*>(buffer.data());
      s.avail_out = buffer.size();
      rc = lzma_code(&s, last ? LZMA_FINISH : LZMA_RUN);
      out.append(buffer.data(), buffer.size() - s.avail_out);
    } while (s.avail_out == 0 || (last && rc == LZMA_OK));
  }
  lzma_end(&s);
  return out;
}

TEST_F(HostileInput, CompressedFilesAreRecognisedByTheirBytesWhateverTheirName) {
  const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  expect_unit_triangle(load_scene(write("gzip-named.obj", gzip_repeated(text, 1))));
  expect_unit_triangle(load_scene(write("xz-named.obj", xz_repeated(text, 1))));
}

TEST_F(HostileInput, DecompressionBombsStopAtTheLimit) {
  // 260 MiB of newlines pack into a few hundred KB; they once inflated whole (3 GB from 3 MB).
  const std::string newlines(1 << 20, '\n');
  for (const auto& [name, packed] :
       {std::pair{std::string("bomb.obj.gz"), gzip_repeated(newlines, 260)},
        std::pair{std::string("bomb.obj.xz"), xz_repeated(newlines, 260)}}) {
    ASSERT_LT(packed.size(), std::size_t(4) << 20);
    const std::string path = write(name, packed);
    const std::string message = error_of([&] { load_scene(path); }, ErrorCode::limit_exceeded);
    EXPECT_NE(message.find(path + ": inflates to more than 256 MiB"), std::string::npos) << message;
  }
}

TEST_F(HostileInput, DevicesAndDirectoriesAreNotReadAsFiles) {
  if (fs::exists("/dev/zero")) {  // once read forever
    const fs::path link = dir_ / "zero.obj";
    fs::create_symlink("/dev/zero", link);
    const std::string message = error_of([&] { load_scene(link.string()); }, ErrorCode::io);
    EXPECT_NE(message.find("zero.obj: cannot read: not a regular file"), std::string::npos)
        << message;
    fs::remove(link);
  }
  const std::string folder = dir_.string();
  EXPECT_NE(error_of([&] { read_rays(folder, RayFormat::irgrid); }, ErrorCode::io)
                .find(folder + ": cannot read rays: not a regular file"),
            std::string::npos);
  EXPECT_NE(error_of([&] { read_views(folder, "x"); }, ErrorCode::io).find(folder + ": "),
            std::string::npos);
}

TEST_F(HostileInput, AViewsFileWithAHugeNumberNamesThePath) {
  const std::string path =
      write("views.json", R"({"x": [{"eye": [1e400, 0, 0], "target": [0, 0, 0]}]})");
  const std::string message = error_of([&] { read_views(path, "x"); }, ErrorCode::io);
  EXPECT_NE(message.find(path + ": malformed JSON"), std::string::npos) << message;
}

TEST_F(HostileInput, AFractionalPlyIndexIsNoVertex) {
  const Scene scene = load_scene(write("frac.ply",
                                       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float "
                                       "x\nproperty float y\nproperty float z\nelement face 1\n"
                                       "property list uchar float vertex_indices\nend_header\n"
                                       "0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n"));
  EXPECT_EQ(scene.triangle_count(), 0u);  // once read as 2
  bool warned = false;
  for (const auto& warning : scene.report.warnings)
    warned |= warning.find("vertex index 2.5 is not a whole number") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST_F(HostileInput, OutputsAreWrittenWholeOrNotAtAll) {
  const std::string path = (dir_ / "out.bin").string();
  write_file_whole(path, std::string("first"));
  write_file_whole(path, std::string("second"));
  std::ifstream file(path);
  std::string text;
  file >> text;
  EXPECT_EQ(text, "second");
  if (fs::exists("/dev/full")) {
    const std::string message =
        error_of([] { write_file_whole("/dev/full", std::string("x")); }, ErrorCode::io);
    EXPECT_NE(message.find("/dev/full: write failed"), std::string::npos) << message;
  }
  EXPECT_NE(error_of([&] { write_file_whole(dir_.string(), std::string("x")); }, ErrorCode::io)
                .find(dir_.string()),
            std::string::npos);
  // A folder that does not exist: no temporary file can be made beside the output.
  EXPECT_NE(error_of([&] { write_file_whole((dir_ / "no" / "x").string(), std::string("x")); },
                     ErrorCode::io)
                .find("cannot create"),
            std::string::npos);
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir_))
    ++files;
  EXPECT_EQ(files, 1u) << "no temporary file left behind";
}

}  // namespace
}  // namespace irgrid
