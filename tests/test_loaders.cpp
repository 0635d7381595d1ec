// Tests of the OBJ / PLY loaders and decompression on small files written to a temp folder.
#include <gtest/gtest.h>
#include <lzma.h>
#include <zlib.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "irgrid/error.h"
#include "irgrid/io/scene.h"

namespace irgrid {
namespace {

namespace fs = std::filesystem;
using Triangle = std::array<std::uint32_t, 3>;

// A fresh folder under the system temp folder, removed with everything in it at the end.
class TempDir {
 public:
  TempDir() {
    std::random_device random;
    path_ = fs::temp_directory_path() /
            ("irgrid-loaders-" + std::to_string(random()) + "-" + std::to_string(random()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }
  std::string write(const std::string& name, const std::string& bytes) const {
    const fs::path file = path_ / name;
    std::ofstream(file, std::ios::binary) << bytes;
    return file.string();
  }

 private:
  fs::path path_;
};

class LoaderTest : public ::testing::Test {
 protected:
  Scene load(const std::string& name, const std::string& bytes) {
    return load_scene(dir_.write(name, bytes));
  }
  // The Error load_scene throws for this file; fails the test when none is thrown.
  Error load_error(const std::string& name, const std::string& bytes) {
    try {
      load(name, bytes);
    } catch (const Error& error) {
      return error;
    }
    ADD_FAILURE() << name << " loaded without an error";
    return Error(ErrorCode::internal, "no error");
  }
  TempDir dir_;
};

bool has_warning(const Scene& scene, const std::string& part) {
  for (const auto& warning : scene.report.warnings)
    if (warning.find(part) != std::string::npos) return true;
  return false;
}

const char* kSquare =
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0\n"
    "v 0 1 0\n"
    "v 0.5 1.5 0\n";

TEST_F(LoaderTest, ObjFanTriangulatesQuadsAndPentagonsInFileOrder) {
  const Scene scene = load("poly.obj", std::string(kSquare) +
                                           "f 1 2 3\n"
                                           "f 1 2 3 4\n"
                                           "f 1 2 3 5 4\n");
  EXPECT_EQ(scene.report.vertices_read, 5u);
  EXPECT_EQ(scene.report.triangles_read, 6u);
  const std::vector<Triangle> expected = {{0, 1, 2}, {0, 1, 2}, {0, 2, 3},
                                          {0, 1, 2}, {0, 2, 4}, {0, 4, 3}};
  EXPECT_EQ(scene.triangles, expected);
  EXPECT_EQ(scene.input_ids, (std::vector<std::uint32_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(scene.report.dropped(), 0u);
  EXPECT_TRUE(scene.report.warnings.empty());
  EXPECT_EQ(scene.name, dir_.path().filename().string());
  EXPECT_EQ(scene.vertices[4], (Vec3f{0.5f, 1.5f, 0}));
}

TEST_F(LoaderTest, ObjNegativeIndicesAreRelativeToVerticesReadSoFar) {
  const Scene scene = load("relative.obj",
                           "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                           "f -3 -2 -1\n"
                           "v 0 0 1\nv 1 0 1\nv 0 1 1\n"
                           "f -3 -2 -1\n"
                           "f 1 -2 -1\n");
  const std::vector<Triangle> expected = {{0, 1, 2}, {3, 4, 5}, {0, 4, 5}};
  EXPECT_EQ(scene.triangles, expected);
}

TEST_F(LoaderTest, ObjCrlfWithTrailingSpacesAddsNoBogusVertex) {
  const Scene scene = load("crlf.obj",
                           "# exported\r\n"
                           "v  0 0 0 \r\n"
                           "v  1 0 0 \r\n"
                           "v  1 1 0\t\r\n"
                           "v  0 1 0 \r\n"
                           "\r\n"
                           "f 1 2 3 \r\n"
                           "f 1 2 3 4 \r\n"
                           "f 4 3 2 1  \r\n");
  EXPECT_EQ(scene.report.vertices_read, 4u);
  EXPECT_EQ(scene.report.triangles_read, 5u);
  EXPECT_EQ(scene.report.dropped(), 0u);
  EXPECT_EQ(scene.triangles[4], (Triangle{3, 1, 0}));
}

TEST_F(LoaderTest, ObjLoneCarriageReturnsEndLines) {
  const Scene scene = load("cr.obj", "v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r");
  EXPECT_EQ(scene.report.vertices_read, 3u);
  EXPECT_EQ(scene.report.triangles_read, 1u);
}

TEST_F(LoaderTest, ObjAcceptsAllFaceVertexForms) {
  const Scene scene = load("forms.obj", std::string(kSquare) +
                                            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                            "vn 0 0 1\n"
                                            "f 1/1/1 2/2/1 3/3/1\n"
                                            "f 1//1 3//1 4//1\n"
                                            "f 1/1 2/2 3/3 4/4\n"
                                            "f -5/-4/-1 -4/-3/-1 -3/-2/-1\n");
  const std::vector<Triangle> expected = {{0, 1, 2}, {0, 2, 3}, {0, 1, 2}, {0, 2, 3}, {0, 1, 2}};
  EXPECT_EQ(scene.triangles, expected);
}

TEST_F(LoaderTest, ObjKnownStatementsAreNotWarnedAbout) {
  const Scene scene = load("known.obj",
                           "mtllib missing.mtl\no thing\ng group\nusemtl stone\n"
                           "s off\ns 1\n" +
                               std::string(kSquare) + "vp 0.5\nl 1 2\np 3\nf 1 2 3\n");
  EXPECT_EQ(scene.report.unknown_statements, 0u);
  EXPECT_TRUE(scene.report.warnings.empty()) << scene.report.warnings.front();
  EXPECT_EQ(scene.report.triangles_read, 1u);
}

TEST_F(LoaderTest, ObjUnknownStatementsGiveOneWarning) {
  const Scene scene = load("unknown.obj", std::string(kSquare) +
                                              "f 1 2 3\n"
                                              "curv 0 1 1 2\n"
                                              "bogus\n"
                                              "cstype bspline\n");
  EXPECT_EQ(scene.report.unknown_statements, 3u);
  ASSERT_EQ(scene.report.warnings.size(), 1u);
  EXPECT_NE(scene.report.warnings[0].find("skipped 3 unknown statements (first: 'curv' at line 7)"),
            std::string::npos)
      << scene.report.warnings[0];
  EXPECT_EQ(scene.report.triangles_read, 1u);
}

TEST_F(LoaderTest, ObjOutOfRangeIndicesAreDroppedNotFatal) {
  const Scene scene = load("range.obj", std::string(kSquare) +
                                            "f 1 2 3\n"
                                            "f 1 2 99\n"
                                            "f -1 -2 -9\n"
                                            "f 1 2 2147483647\n");
  EXPECT_EQ(scene.report.triangles_read, 4u);
  EXPECT_EQ(scene.report.dropped_bad_index, 3u);
  EXPECT_EQ(scene.triangles, (std::vector<Triangle>{{0, 1, 2}}));
  EXPECT_EQ(scene.input_ids, (std::vector<std::uint32_t>{0}));
  EXPECT_TRUE(has_warning(scene, "dropped 3 triangles with an out-of-range vertex index"));
  EXPECT_TRUE(has_warning(scene, "line 7: vertex index 99 is past the file's 5 vertices"));
}

TEST_F(LoaderTest, ObjNamesTheFirstOutOfRangeReference) {
  // A relative index before its vertex is out of range where it stands.
  const Scene relative = load("relative.obj", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\nf 1 2 9\n");
  EXPECT_TRUE(has_warning(
      relative, "line 3: vertex index -3 reaches before the first vertex (2 precede it)"));
  // An absolute index past the vertices read so far is fine when the file defines them later.
  const Scene forward =
      load("forward.obj", "f 1 2 3\nf 1 2 5\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 9\n");
  EXPECT_EQ(forward.report.dropped_bad_index, 2u);
  EXPECT_TRUE(has_warning(forward, "line 2: vertex index 5 is past the file's 4 vertices"));
  const Scene fine = load("fine.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
  EXPECT_EQ(fine.report.dropped_bad_index, 0u);
  EXPECT_TRUE(fine.report.warnings.empty()) << fine.report.warnings[0];
}

TEST_F(LoaderTest, ObjNonFiniteCoordinatesAreDropped) {
  const Scene scene = load("nan.obj",
                           "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                           "v nan 0 0\nv 0 inf 0\nv 0 0 -1e300\n"
                           "f 1 2 3\nf 1 2 4\nf 5 1 2\nf 1 6 2\n");
  EXPECT_EQ(scene.report.vertices_read, 6u);
  EXPECT_EQ(scene.report.dropped_nonfinite, 3u);
  EXPECT_EQ(scene.triangle_count(), 1u);
  EXPECT_TRUE(std::isnan(scene.vertices[3][0]));
  EXPECT_TRUE(std::isinf(scene.vertices[4][1]));
  EXPECT_TRUE(has_warning(scene, "dropped 3 triangles with a NaN or infinite"));
}

TEST_F(LoaderTest, ObjDegenerateTrianglesAreDropped) {
  const Scene scene = load("degenerate.obj", std::string(kSquare) +
                                                 "v 2 0 0\n"
                                                 "f 1 1 2\n"
                                                 "f 1 2 6\n"
                                                 "f 1 2 3\n");
  EXPECT_EQ(scene.report.dropped_degenerate, 2u);
  EXPECT_EQ(scene.input_ids, (std::vector<std::uint32_t>{2}));
  EXPECT_TRUE(has_warning(scene, "dropped 2 degenerate"));
}

TEST_F(LoaderTest, ObjFacesWithFewerThanThreeVerticesAreWarnedAbout) {
  const Scene scene = load("short.obj", std::string(kSquare) + "f 1 2\nf 1 2 3\nf 3\n");
  EXPECT_EQ(scene.report.triangles_read, 1u);
  EXPECT_TRUE(has_warning(scene, "skipped 2 faces with fewer than 3 vertices (first at line 6)"));
}

TEST_F(LoaderTest, ObjFaceWithMoreThan255VerticesKeepsAllTriangles) {
  std::string text;
  const int n = 300;
  for (int i = 0; i < n; ++i)
    text += "v " + std::to_string(std::cos(i * 2 * M_PI / n)) + " " +
            std::to_string(std::sin(i * 2 * M_PI / n)) + " 0\n";
  text += "f";
  for (int i = 1; i <= n; ++i)
    text += " " + std::to_string(i);
  text += "\nf 1 2 3\n";
  const Scene scene = load("big.obj", text);
  EXPECT_EQ(scene.report.triangles_read, std::uint64_t(n - 2 + 1));
  EXPECT_EQ(scene.triangles.back(), (Triangle{0, 1, 2}));
  EXPECT_EQ(scene.triangles[n - 3], (Triangle{0, std::uint32_t(n - 2), std::uint32_t(n - 1)}));
}

TEST_F(LoaderTest, ObjMalformedNumbersNameFileAndLine) {
  const struct {
    const char* text;
    const char* expected;
  } cases[] = {
      {"v 0 0 0\nv 1 0 0\nv 1 abc 3\nf 1 2 3\n", "line 3: malformed number 'abc'"},
      {"v 0 0 0\nv 1 0 0\nv 1 2\n", "line 3: vertex needs 3 coordinates"},
      {"v 0 0 0\nv 1 0 0\nv 1 2 3\n\nf 1 x 2\n", "line 5: malformed face index 'x'"},
      {"v 0 0 0\nv 1 0 0\nv 1 2 3\nf 1 2x 3\n", "line 4: malformed face index '2x'"},
      {"v 0 0 0\nv 1 0 0\nv 1 2 3\nf 0 1 2\n", "line 4: index 0 is invalid"},
      {"v 0 0 0\nv 1 0 0\nv 1 2 3\nf 1/ 2 3\n", "line 4: malformed face index '1/'"},
      {"v 0 0 0\nv 1 0 0\nv 1 2.5.6 3\n", "line 3: malformed number '2.5.6'"},
  };
  for (const auto& c : cases) {
    const Error error = load_error("bad.obj", c.text);
    EXPECT_EQ(error.code(), ErrorCode::io);
    const std::string what = error.what();
    EXPECT_NE(what.find("bad.obj: "), std::string::npos) << what;
    EXPECT_NE(what.find(c.expected), std::string::npos) << what;
  }
}

TEST_F(LoaderTest, ObjTinyobjloaderErrorsNamePath) {
  // A zero index in an 'l' statement is rejected by tinyobjloader itself, not by the pre-scan.
  const Error error = load_error("line.obj", "v 0 0 0\nv 1 0 0\nl 0 1\n");
  EXPECT_EQ(error.code(), ErrorCode::io);
  EXPECT_NE(std::string(error.what()).find("line.obj: "), std::string::npos) << error.what();
  EXPECT_NE(std::string(error.what()).find("line 3"), std::string::npos) << error.what();
}

TEST_F(LoaderTest, ObjHugeIndexIsALimitError) {
  const Error error = load_error("huge.obj", "v 0 0 0\nv 1 0 0\nv 1 2 3\nf 1 2 4294967297\n");
  EXPECT_EQ(error.code(), ErrorCode::limit_exceeded);
  EXPECT_NE(std::string(error.what()).find("4294967297"), std::string::npos);
}

TEST_F(LoaderTest, ObjLeadingPlusAndExponentsParse) {
  const Scene scene = load("plus.obj", "v +1 -2 3e-1\nv 1.5E+2 .5 -.25\nv 0 0 1\nf 1 2 3\n");
  EXPECT_EQ(scene.vertices[0], (Vec3f{1, -2, 0.3f}));
  EXPECT_EQ(scene.vertices[1], (Vec3f{150, 0.5f, -0.25f}));
}

// Writes PLY bodies in either byte order, whatever this machine's order is.
class ByteWriter {
 public:
  explicit ByteWriter(bool big_endian) : big_endian_(big_endian) {}
  template <typename T>
  ByteWriter& put(T value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    const bool native_big = std::endian::native == std::endian::big;
    for (std::size_t i = 0; i < sizeof(T); ++i)
      data_ += char(bytes[big_endian_ == native_big ? i : sizeof(T) - 1 - i]);
    return *this;
  }
  const std::string& data() const { return data_; }

 private:
  bool big_endian_;
  std::string data_;
};

TEST_F(LoaderTest, PlyAsciiWithExtraPropertiesAndLists) {
  const Scene scene = load("mesh.ply",
                           "ply\n"
                           "format ascii 1.0\n"
                           "comment made by hand\n"
                           "obj_info for a test\n"
                           "element vertex 4\n"
                           "property float confidence\n"
                           "property float x\n"
                           "property list uchar int neighbours\n"
                           "property float y\n"
                           "property double z\n"
                           "element face 3\n"
                           "property uchar intensity\n"
                           "property list uchar int vertex_indices\n"
                           "property list uchar float texcoord\n"
                           "element edge 1\n"
                           "property int vertex1\n"
                           "property int vertex2\n"
                           "end_header\n"
                           "0.5 0 2 1 2 0 0\n"
                           "0.5 1 0 0 0\n"
                           "0.5 1 1 3 1 0 \n"
                           "0.5 0 0 1 0\n"
                           "7 4 0 1 2 3 2 0.5 0.5\n"
                           "7 3 0 1 2 0\n"
                           "7 2 0 1 0\n"
                           "0 1\n");
  EXPECT_EQ(scene.report.vertices_read, 4u);
  EXPECT_EQ(scene.report.triangles_read, 3u);
  EXPECT_EQ(scene.vertices[2], (Vec3f{1, 1, 0}));
  EXPECT_EQ(scene.triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}, {0, 1, 2}}));
  EXPECT_TRUE(has_warning(scene, "skipped 1 faces with fewer than 3 vertices"));
  EXPECT_EQ(scene.report.unknown_statements, 0u);
}

TEST_F(LoaderTest, PlyElementWithoutPropertiesTakesNoTimeWhateverItsCount) {
  // Found by fuzz_ply: an element of 1.7e17 records without properties spun for minutes.
  const Scene scene = load("empty-records.ply",
                           "ply\nformat ascii 1.0\nelement marker 177777757777777777\n"
                           "element vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 1\n"
                           "property list uchar int vertex_indices\nend_header\n"
                           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(scene.report.vertices_read, 3u);
  EXPECT_EQ(scene.report.triangles_read, 1u);
}

TEST_F(LoaderTest, PlyAsciiMalformedNumberNamesLine) {
  const Error error = load_error("bad.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 2\n"
                                 "property float x\nproperty float y\nproperty float z\n"
                                 "element face 1\nproperty list uchar int vertex_indices\n"
                                 "end_header\n0 0 0\n1 zero 0\n3 0 1 1\n");
  EXPECT_EQ(error.code(), ErrorCode::io);
  const std::string what = error.what();
  EXPECT_NE(what.find("bad.ply: line 11: malformed number 'zero' in element 'vertex'"),
            std::string::npos)
      << what;
}

TEST_F(LoaderTest, PlyAsciiTruncatedNamesElement) {
  const Error error = load_error("short.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 2\n"
                                 "property float x\nproperty float y\nproperty float z\n"
                                 "element face 1\nproperty list uchar int vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n3 0 1\n");
  const std::string what = error.what();
  EXPECT_NE(what.find("short.ply: line 12: unexpected end of file in element 'face'"),
            std::string::npos)
      << what;
}

// Header of a small binary PLY: float x y z plus a double and a list to skip in vertex,
// uchar intensity before and a float list after the index list in face.
std::string binary_header(const char* format, const char* index_type) {
  return std::string("ply\nformat ") + format +
         " 1.0\n"
         "element vertex 4\n"
         "property float x\nproperty float32 y\nproperty float z\n"
         "property float64 quality\n"
         "property list uint8 int16 ring\n"
         "element face 2\n"
         "property uchar intensity\n"
         "property list uchar " +
         index_type +
         " vertex_indices\n"
         "property list int32 float texcoord\n"
         "end_header\n";
}

template <typename Index>
std::string binary_body(bool big_endian) {
  ByteWriter out(big_endian);
  const float positions[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  for (const auto& p : positions) {
    out.put(p[0]).put(p[1]).put(p[2]).put(0.25).put(std::uint8_t(2));
    out.put(std::int16_t(-1)).put(std::int16_t(7));
  }
  out.put(std::uint8_t(9)).put(std::uint8_t(4));  // a quad
  for (int i : {0, 1, 2, 3})
    out.put(Index(i));
  out.put(std::int32_t(2)).put(0.5f).put(0.5f);
  out.put(std::uint8_t(9)).put(std::uint8_t(3));  // a triangle, then an empty texcoord list
  for (int i : {3, 2, 1})
    out.put(Index(i));
  out.put(std::int32_t(0));
  return out.data();
}

void expect_square(const Scene& scene) {
  EXPECT_EQ(scene.report.vertices_read, 4u);
  EXPECT_EQ(scene.report.triangles_read, 3u);
  EXPECT_EQ(scene.vertices[1], (Vec3f{1, 0, 0}));
  EXPECT_EQ(scene.vertices[3], (Vec3f{0, 1, 0}));
  EXPECT_EQ(scene.triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}, {3, 2, 1}}));
  EXPECT_EQ(scene.report.dropped(), 0u);
}

TEST_F(LoaderTest, PlyBinaryLittleEndianIntIndices) {
  expect_square(load(
      "le.ply", binary_header("binary_little_endian", "int") + binary_body<std::int32_t>(false)));
}

TEST_F(LoaderTest, PlyBinaryBigEndianUcharIndices) {
  expect_square(load(
      "be.ply", binary_header("binary_big_endian", "uchar") + binary_body<std::uint8_t>(true)));
}

TEST_F(LoaderTest, PlyBinaryBigEndianUintIndicesAndVertexIndexName) {
  std::string header = binary_header("binary_big_endian", "uint32");
  header.replace(header.find("vertex_indices"), 14, "vertex_index");
  expect_square(load("be32.ply", header + binary_body<std::uint32_t>(true)));
}

TEST_F(LoaderTest, PlyBinaryDoubleCoordinates) {
  ByteWriter out(true);
  for (double v : {0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0})
    out.put(v);
  out.put(std::uint8_t(3)).put(std::int32_t(0)).put(std::int32_t(1)).put(std::int32_t(2));
  const Scene scene = load("double.ply",
                           "ply\r\nformat binary_big_endian 1.0\r\nelement vertex 3\r\n"
                           "property double x\r\nproperty double y\r\nproperty double z\r\n"
                           "element face 1\r\nproperty list uchar int vertex_indices\r\n"
                           "end_header\r\n" +
                               out.data());
  EXPECT_EQ(scene.vertices[2], (Vec3f{0, 1, 0}));
  EXPECT_EQ(scene.triangle_count(), 1u);
}

TEST_F(LoaderTest, PlyNegativeAndOutOfRangeIndicesAreDropped) {
  ByteWriter out(false);
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f})
    out.put(v);
  for (std::int32_t bad : {-1, 3, 1}) {
    out.put(std::uint8_t(3)).put(std::int32_t(0)).put(std::int32_t(bad)).put(std::int32_t(2));
  }
  const Scene scene = load("bad-index.ply",
                           "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                           "property float x\nproperty float y\nproperty float z\n"
                           "element face 3\nproperty list uchar int vertex_indices\n"
                           "end_header\n" +
                               out.data());
  EXPECT_EQ(scene.report.triangles_read, 3u);
  EXPECT_EQ(scene.report.dropped_bad_index, 2u);
  EXPECT_EQ(scene.input_ids, (std::vector<std::uint32_t>{2}));
  EXPECT_TRUE(has_warning(
      scene, "face 0 (counting from 0): vertex index -1 is not below the file's 3 vertices"));
}

TEST_F(LoaderTest, PlyTruncatedBinaryNamesPathAndElement) {
  const std::string whole =
      binary_header("binary_little_endian", "int") + binary_body<std::int32_t>(false);
  const Error error = load_error("cut.ply", whole.substr(0, whole.size() - 10));
  EXPECT_EQ(error.code(), ErrorCode::io);
  const std::string what = error.what();
  EXPECT_NE(what.find("cut.ply: truncated binary data in element 'face' (record 2 of 2)"),
            std::string::npos)
      << what;
  const Error in_vertices = load_error("cut2.ply", whole.substr(0, whole.size() - 80));
  EXPECT_NE(std::string(in_vertices.what()).find("element 'vertex'"), std::string::npos)
      << in_vertices.what();
}

TEST_F(LoaderTest, PlyHugeCountsFailWithoutHugeAllocations) {
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  const Error too_many =
      load_error("many.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 5000000000\n" +
                                 xyz + "end_header\n" + std::string(12, '\0'));
  EXPECT_EQ(too_many.code(), ErrorCode::limit_exceeded);
  EXPECT_NE(std::string(too_many.what()).find("many.ply: 5000000000 vertices"), std::string::npos)
      << too_many.what();
  const Error lying =
      load_error("lying.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1\n" + xyz +
                                  "element face 4000000000\n"
                                  "property list uint int vertex_indices\nend_header\n" +
                                  std::string(12, '\0') + std::string(4, '\xff'));
  EXPECT_EQ(lying.code(), ErrorCode::io);
  EXPECT_NE(std::string(lying.what()).find("lying.ply: invalid list length"), std::string::npos)
      << lying.what();
}

TEST_F(LoaderTest, PlyHeaderErrors) {
  EXPECT_NE(std::string(load_error("a.ply", "solid x\n").what()).find("not a PLY file"),
            std::string::npos);
  EXPECT_NE(std::string(load_error("b.ply", "ply\nformat ascii 1.0\nelement vertex 1\n").what())
                .find("not terminated"),
            std::string::npos);
  const Error bad_type =
      load_error("c.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n");
  EXPECT_NE(std::string(bad_type.what()).find("c.ply: line 4: unknown PLY property type 'quad'"),
            std::string::npos)
      << bad_type.what();
  const Error no_xyz = load_error(
      "d.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n");
  EXPECT_NE(std::string(no_xyz.what()).find("x, y and z"), std::string::npos);
}

std::string gzip(const std::string& data) {
  z_stream z{};
  EXPECT_EQ(deflateInit2(&z, 9, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&z, uLong(data.size())) + 64, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = uInt(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  EXPECT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

std::string xz(const std::string& data) {
  std::string out(lzma_stream_buffer_bound(data.size()), '\0');
  std::size_t used = 0;
  EXPECT_EQ(lzma_easy_buffer_encode(6, LZMA_CHECK_CRC64, nullptr,
                                    reinterpret_cast<const std::uint8_t*>(data.data()), data.size(),
                                    reinterpret_cast<std::uint8_t*>(out.data()), &used, out.size()),
            LZMA_OK);
  out.resize(used);
  return out;
}

// Large enough that the decoders must grow their output several times.
std::string big_obj_text() {
  std::string text;
  for (int i = 0; i < 20000; ++i)
    text += "v " + std::to_string(i) + " " + std::to_string(i % 7) + " " + std::to_string(i % 13) +
            "\n";
  for (int i = 1; i + 2 <= 20000; i += 3)
    text +=
        "f " + std::to_string(i) + " " + std::to_string(i + 1) + " " + std::to_string(i + 2) + "\n";
  return text;
}

TEST_F(LoaderTest, CompressedRoundTripsIncludingConcatenatedMembers) {
  const std::string text = big_obj_text();
  const std::size_t half = text.size() / 2;
  const std::string plain = dir_.write("plain.obj", text);
  const std::string gz = dir_.write("mesh.obj.gz", gzip(text));
  const std::string gz2 =
      dir_.write("two.obj.gz", gzip(text.substr(0, half)) + gzip(text.substr(half)));
  const std::string xz1 = dir_.write("mesh.obj.xz", xz(text));
  const std::string xz2 =
      dir_.write("two.OBJ.XZ", xz(text.substr(0, half)) + xz(text.substr(half)));
  for (const auto& path : {plain, gz, gz2, xz1, xz2}) {
    EXPECT_EQ(read_file_decompressed(path), text) << path;
    const Scene scene = load_scene(path);
    EXPECT_EQ(scene.report.vertices_read, 20000u) << path;
    EXPECT_EQ(scene.report.triangles_read, 6666u) << path;
    EXPECT_EQ(scene.source, path);
  }
}

TEST_F(LoaderTest, CompressedPlyRoundTrip) {
  const std::string ply =
      binary_header("binary_big_endian", "int") + binary_body<std::int32_t>(true);
  expect_square(load_scene(dir_.write("mesh.ply.gz", gzip(ply))));
  expect_square(load_scene(dir_.write("mesh.ply.xz", xz(ply))));
}

TEST_F(LoaderTest, PlainFilesAreReturnedByteForByte) {
  const std::string bytes("a\0b\r\n\xff", 6);
  EXPECT_EQ(read_file_decompressed(dir_.write("raw.bin", bytes)), bytes);
  EXPECT_EQ(read_file_decompressed(dir_.write("empty.bin", "")), "");
}

TEST_F(LoaderTest, CorruptCompressedDataNamesPath) {
  std::string packed = xz(big_obj_text());
  packed[packed.size() / 2] ^= 0x55;
  const Error corrupt = load_error("corrupt.obj.xz", packed);
  EXPECT_EQ(corrupt.code(), ErrorCode::io);
  EXPECT_NE(std::string(corrupt.what()).find("corrupt.obj.xz: corrupt xz data"), std::string::npos)
      << corrupt.what();
  const Error cut_xz = load_error("cut.obj.xz", packed.substr(0, 100));
  EXPECT_NE(std::string(cut_xz.what()).find("cut.obj.xz: "), std::string::npos) << cut_xz.what();
  const std::string gz = gzip(big_obj_text());
  const Error cut_gz = load_error("cut.obj.gz", gz.substr(0, gz.size() / 2));
  EXPECT_NE(std::string(cut_gz.what()).find("cut.obj.gz: truncated gzip data"), std::string::npos)
      << cut_gz.what();
  const Error not_gz = load_error("text.obj.gz", "v 0 0 0\n");
  EXPECT_NE(std::string(not_gz.what()).find("text.obj.gz: corrupt gzip data"), std::string::npos)
      << not_gz.what();
}

TEST_F(LoaderTest, MissingFileNamesPath) {
  const std::string path = (dir_.path() / "nowhere.obj").string();
  try {
    load_scene(path);
    FAIL() << "no error";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::io);
    EXPECT_EQ(std::string(error.what()), path + ": no such file");
  }
  try {
    read_file_decompressed(path);
    FAIL() << "no error";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::io);
    EXPECT_NE(std::string(error.what()).find(path + ": cannot open: "), std::string::npos);
  }
}

TEST_F(LoaderTest, UnknownExtensionIsAnError) {
  const Error error = load_error("mesh.stl", "solid\n");
  EXPECT_EQ(error.code(), ErrorCode::io);
  EXPECT_NE(std::string(error.what()).find("mesh.stl: unknown scene format '.stl'"),
            std::string::npos)
      << error.what();
  EXPECT_EQ(load_error("mesh.gz", "").code(), ErrorCode::io);
}

TEST_F(LoaderTest, SceneNameIsTheFileStemWithoutAFolder) {
  dir_.write("stem.obj.gz", gzip("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
  const fs::path previous = fs::current_path();
  fs::current_path(dir_.path());
  const Scene bare = load_scene("stem.obj.gz");
  const Scene dotted = load_scene("./stem.obj.gz");
  fs::current_path(previous);
  EXPECT_EQ(bare.name, "stem");
  EXPECT_EQ(dotted.name, "stem");
  EXPECT_EQ(dotted.source, "./stem.obj.gz");
}

TEST_F(LoaderTest, BuiltinSpecsGoToTheGenerator) {
  const auto names = builtin_scene_names();
  ASSERT_FALSE(names.empty());
  const Scene scene = load_scene("builtin:" + names.front().first);
  EXPECT_GT(scene.triangle_count(), 0u);
}

TEST_F(LoaderTest, ExtensionsAreCaseInsensitive) {
  const Scene scene = load("UPPER.OBJ", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(scene.triangle_count(), 1u);
}

}  // namespace
}  // namespace irgrid
