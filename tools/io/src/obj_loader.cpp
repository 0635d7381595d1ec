// Wavefront OBJ loader: tinyobjloader parses, a pre-scan validates and fills its gaps.
//
// tinyobjloader 2.0rc10 quirks this file works around (all checked against the installed header):
//  - malformed numbers are accepted silently ("v 1 abc 3" gives y = 0, "f 1 2x 3" gives 2),
//    and "nan"/"inf" coordinates are read as 0, so a pre-scan validates every v and f line
//    with std::from_chars, reports the line, and restores the non-finite coordinates;
//  - out-of-range positive indices are kept as they are (only a warning at the end);
//    relative indices before the first vertex become negative: both are passed on as
//    out-of-range so drop_invalid_triangles counts them;
//  - per-face vertex counts are stored as unsigned char, so faces with 256+ vertices wrap;
//    the pre-scan remembers their true sizes;
//  - faces with fewer than 3 vertices are dropped silently (a warning string only);
//  - indices are int: more than 2^31-1 vertices cannot be addressed.
#include <tiny_obj_loader.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <istream>
#include <limits>
#include <streambuf>
#include <string>
#include <string_view>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "irgrid/error.h"
#include "irgrid/io/scene.h"

namespace irgrid::detail {
namespace {

constexpr std::uint32_t kInvalidIndex = 0xFFFFFFFFu;
constexpr std::uint64_t kMaxCount = 0xFFFFFFFEull;  // 2^32-2: uint32 ids stay below the sentinel
constexpr std::uint64_t kMaxObjVertices = std::numeric_limits<int>::max();  // tinyobj uses int

// What the pre-scan learned about the text besides "it is well formed".
struct ObjSummary {
  std::uint64_t vertices = 0;
  std::uint64_t faces = 0;  // faces with at least 3 vertices
  std::uint64_t triangles = 0;
  std::uint64_t short_faces = 0;  // fewer than 3 vertices
  std::uint64_t first_short_face_line = 0;
  std::uint64_t unknown_statements = 0;
  std::string first_unknown;
  std::uint64_t first_unknown_line = 0;
  std::vector<std::pair<std::uint64_t, Vec3f>> nonfinite_vertices;  // (vertex, position)
  std::vector<std::pair<std::uint64_t, std::uint64_t>> big_faces;   // (face, vertex count >255)
  // Out-of-range vertex references (line, index as written): a relative one before its vertex
  // is out of range at once; an absolute one past the vertices read so far only if the file
  // never defines that many, so those are kept while each exceeds every earlier one (the first
  // past the final count is then among them).
  std::uint64_t first_bad_relative_line = 0;
  std::int64_t first_bad_relative_index = 0;
  std::uint64_t first_bad_relative_preceding = 0;  // vertices before that line
  std::vector<std::pair<std::uint64_t, std::int64_t>> forward_references;
};

// Splits text into lines the way tinyobjloader does: "\n", "\r\n" or a lone "\r".
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    std::size_t end = pos_;
    while (end < text_.size() && text_[end] != '\n' && text_[end] != '\r')
      ++end;
    line = text_.substr(pos_, end - pos_);
    pos_ = end + 1;
    if (end < text_.size() && text_[end] == '\r' && pos_ < text_.size() && text_[pos_] == '\n')
      ++pos_;
    ++number_;
    return true;
  }
  std::uint64_t number() const { return number_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::uint64_t number_ = 0;
};

bool is_blank(char c) {
  return c == ' ' || c == '\t';
}

// Next blank-separated token of `line`, consuming it; empty at the end of the line.
std::string_view next_token(std::string_view& line) {
  std::size_t begin = 0;
  while (begin < line.size() && is_blank(line[begin]))
    ++begin;
  std::size_t end = begin;
  while (end < line.size() && !is_blank(line[end]))
    ++end;
  const auto token = line.substr(begin, end - begin);
  line.remove_prefix(end);
  return token;
}

class ObjPrescan {
 public:
  explicit ObjPrescan(const std::string& path) : path_(path) {}
  ObjSummary run(std::string_view text);

 private:
  [[noreturn]] void fail(std::string_view what, std::string_view token) const;
  double parse_coordinate(std::string_view token) const;
  void scan_vertex(std::string_view rest);
  std::int64_t parse_index(std::string_view text, std::string_view token) const;
  std::int64_t check_vertex_ref(std::string_view token) const;
  void note_vertex_index(std::int64_t index);
  void scan_face(std::string_view rest);
  void note_unknown(std::string_view keyword);

  const std::string& path_;
  std::uint64_t line_ = 0;
  ObjSummary summary_;
};

/// A token as a message may quote it: at most 40 bytes, other than printable ASCII as \xNN
/// (a binary file read as OBJ must not print raw bytes to the terminal).
std::string printable(std::string_view token) {
  std::string out;
  for (std::size_t i = 0; i < token.size() && i < 40; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7F) {
      out += char(c);
    } else {
      constexpr char kHex[] = "0123456789abcdef";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  if (token.size() > 40) out += "...";
  return out;
}

void ObjPrescan::fail(std::string_view what, std::string_view token) const {
  throw Error(ErrorCode::io, path_ + ": line " + std::to_string(line_) + ": " + std::string(what) +
                                 " '" + printable(token) + "'");
}

double ObjPrescan::parse_coordinate(std::string_view token) const {
  std::string_view digits = token;
  // from_chars rejects a leading '+', which OBJ writers do emit.
  if (digits.size() > 1 && digits[0] == '+' && digits[1] != '-') digits.remove_prefix(1);
  double value = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (end != digits.data() + digits.size() || digits.empty()) fail("malformed number", token);
  if (ec == std::errc::result_out_of_range)  // overflow to +-inf, underflow to 0, like strtod
    value = std::strtod(std::string(digits).c_str(), nullptr);
  else if (ec != std::errc())
    fail("malformed number", token);
  return value;
}

void ObjPrescan::scan_vertex(std::string_view rest) {
  double xyz[3] = {0, 0, 0};
  int count = 0;
  for (auto token = next_token(rest); !token.empty(); token = next_token(rest)) {
    const double value = parse_coordinate(token);  // w or r g b may follow x y z
    if (count < 3) xyz[count] = value;
    ++count;
  }
  if (count < 3) fail("vertex needs 3 coordinates, got", std::to_string(count));
  const Vec3f position{float(xyz[0]), float(xyz[1]), float(xyz[2])};
  if (!std::isfinite(position[0]) || !std::isfinite(position[1]) || !std::isfinite(position[2]))
    summary_.nonfinite_vertices.emplace_back(summary_.vertices, position);
  ++summary_.vertices;
}

// One index of a v/vt/vn reference; 0 and values beyond int are errors.
std::int64_t ObjPrescan::parse_index(std::string_view text, std::string_view token) const {
  if (text.size() > 1 && text[0] == '+' && text[1] != '-') text.remove_prefix(1);
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty())
    fail("malformed face index", token);
  if (value == 0) fail("index 0 is invalid (OBJ indices start at 1) in", token);
  if (value > std::int64_t(kMaxObjVertices) || value < -std::int64_t(kMaxObjVertices))
    throw Error(ErrorCode::limit_exceeded, path_ + ": line " + std::to_string(line_) + ": index " +
                                               std::to_string(value) +
                                               " is beyond the OBJ limit of 2^31-1 vertices");
  return value;
}

// Accepts v, v/vt, v/vt/vn and v//vn; returns the vertex index.
std::int64_t ObjPrescan::check_vertex_ref(std::string_view token) const {
  std::string_view rest = token;
  std::int64_t vertex = 0;
  for (int part = 0; part < 3; ++part) {
    const auto slash = rest.find('/');
    const auto field = rest.substr(0, slash);
    const bool optional_empty = part == 1 && field.empty() && slash != std::string_view::npos;
    if (!optional_empty) {
      const std::int64_t index = parse_index(field, token);
      if (part == 0) vertex = index;
    }
    if (slash == std::string_view::npos) return vertex;
    rest.remove_prefix(slash + 1);
  }
  fail("malformed face vertex", token);
}

void ObjPrescan::note_vertex_index(std::int64_t index) {
  const auto read = std::int64_t(summary_.vertices);
  if (index < 0 && index + read < 0 && summary_.first_bad_relative_line == 0) {
    summary_.first_bad_relative_line = line_;
    summary_.first_bad_relative_index = index;
    summary_.first_bad_relative_preceding = summary_.vertices;
  }
  auto& forward = summary_.forward_references;
  if (index > read && (forward.empty() || index > forward.back().second))
    forward.emplace_back(line_, index);
}

void ObjPrescan::scan_face(std::string_view rest) {
  std::uint64_t count = 0;
  for (auto token = next_token(rest); !token.empty(); token = next_token(rest)) {
    note_vertex_index(check_vertex_ref(token));
    ++count;
  }
  if (count < 3) {
    if (summary_.short_faces++ == 0) summary_.first_short_face_line = line_;
    return;
  }
  if (count > 255) summary_.big_faces.emplace_back(summary_.faces, count);
  ++summary_.faces;
  summary_.triangles += count - 2;
}

void ObjPrescan::note_unknown(std::string_view keyword) {
  if (summary_.unknown_statements++ == 0) {
    summary_.first_unknown = std::string(keyword.substr(0, 40));
    summary_.first_unknown_line = line_;
  }
}

ObjSummary ObjPrescan::run(std::string_view text) {
  static constexpr std::string_view kKnown[] = {"vt", "vn", "vp", "l",      "p",
                                                "o",  "g",  "s",  "mtllib", "usemtl"};
  LineReader lines(text);
  std::string_view line;
  while (lines.next(line)) {
    line_ = lines.number();
    const auto keyword = next_token(line);
    if (keyword.empty() || keyword[0] == '#') continue;
    if (keyword == "v") {
      scan_vertex(line);
    } else if (keyword == "f") {
      scan_face(line);
    } else if (std::find(std::begin(kKnown), std::end(kKnown), keyword) == std::end(kKnown)) {
      note_unknown(keyword);
    }
  }
  return std::move(summary_);
}

// A read-only stream over text already in memory (an istringstream would copy it).
class MemoryBuffer : public std::streambuf {
 public:
  explicit MemoryBuffer(std::string& text) {
    setg(text.data(), text.data(), text.data() + text.size());
  }
};

void check_limits(const std::string& path, const ObjSummary& summary) {
  if (summary.vertices > kMaxObjVertices)
    throw Error(ErrorCode::limit_exceeded,
                path + ": " + std::to_string(summary.vertices) +
                    " vertices exceed the OBJ loader's limit of 2^31-1 (tinyobjloader uses int)");
  if (summary.triangles > kMaxCount)
    throw Error(ErrorCode::limit_exceeded, path + ": " + std::to_string(summary.triangles) +
                                               " triangles exceed the limit of 2^32-2");
}

void run_tinyobj(const std::string& path, std::string& text, tinyobj::attrib_t& attrib,
                 std::vector<tinyobj::shape_t>& shapes) {
  MemoryBuffer buffer(text);
  std::istream stream(&buffer);
  std::vector<tinyobj::material_t> materials;
  std::string warnings, errors;
  // No material reader: mtllib is ignored. No triangulation: we fan from the first vertex
  // ourselves so counts match other tools. No colour fallback: it would store 3 floats/vertex.
  const bool ok = tinyobj::LoadObj(&attrib, &shapes, &materials, &warnings, &errors, &stream,
                                   nullptr, false, false);
  // tinyobjloader's warnings (missing materials, out-of-range indices, short faces) are
  // reported by us more precisely, so they are not passed on.
  if (!ok || !errors.empty()) {
    while (!errors.empty() && (errors.back() == '\n' || errors.back() == '.'))
      errors.pop_back();
    throw Error(ErrorCode::io, path + ": " + (errors.empty() ? "tinyobjloader failed" : errors));
  }
}

[[noreturn]] void throw_mismatch(const std::string& path, const char* what, std::uint64_t ours,
                                 std::uint64_t theirs) {
  throw Error(ErrorCode::internal, path + ": tinyobjloader read " + std::to_string(theirs) + " " +
                                       what + " but the pre-scan counted " + std::to_string(ours));
}

void copy_vertices(const std::string& path, const ObjSummary& summary,
                   const tinyobj::attrib_t& attrib, Scene& scene) {
  const std::size_t count = attrib.vertices.size() / 3;
  if (count != summary.vertices) throw_mismatch(path, "vertices", summary.vertices, count);
  scene.vertices.resize(count);
  for (std::size_t i = 0; i < count; ++i)
    scene.vertices[i] = {float(attrib.vertices[3 * i]), float(attrib.vertices[3 * i + 1]),
                         float(attrib.vertices[3 * i + 2])};
  for (const auto& [index, position] : summary.nonfinite_vertices)
    scene.vertices[index] = position;
}

std::uint32_t to_scene_index(int obj_index) {
  return obj_index < 0 ? kInvalidIndex : std::uint32_t(obj_index);
}

// Fan-triangulates every face from its first vertex, in file order.
void copy_triangles(const std::string& path, const ObjSummary& summary,
                    const std::vector<tinyobj::shape_t>& shapes, Scene& scene) {
  scene.triangles.reserve(summary.triangles);
  std::uint64_t face = 0;
  std::size_t next_big = 0;
  for (const auto& shape : shapes) {
    const auto& indices = shape.mesh.indices;
    std::size_t first = 0;
    for (const unsigned char stored_size : shape.mesh.num_face_vertices) {
      std::size_t size = stored_size;
      if (next_big < summary.big_faces.size() && summary.big_faces[next_big].first == face)
        size = summary.big_faces[next_big++].second;
      if (first + size > indices.size())
        throw_mismatch(path, "face indices", first + size, indices.size());
      const auto anchor = to_scene_index(indices[first].vertex_index);
      for (std::size_t k = 1; k + 1 < size; ++k)
        scene.triangles.push_back({anchor, to_scene_index(indices[first + k].vertex_index),
                                   to_scene_index(indices[first + k + 1].vertex_index)});
      first += size;
      ++face;
    }
  }
  if (face != summary.faces) throw_mismatch(path, "faces", summary.faces, face);
}

// The first out-of-range vertex reference, as "line L: what is wrong"; empty when none is.
std::string first_bad_vertex_reference(const ObjSummary& summary) {
  std::uint64_t line = summary.first_bad_relative_line;
  std::string what = "vertex index " + std::to_string(summary.first_bad_relative_index) +
                     " reaches before the first vertex (" +
                     std::to_string(summary.first_bad_relative_preceding) + " precede it)";
  for (const auto& [forward_line, index] : summary.forward_references)
    if (index > std::int64_t(summary.vertices)) {
      if (line == 0 || forward_line < line) {
        line = forward_line;
        what = "vertex index " + std::to_string(index) + " is past the file's " +
               std::to_string(summary.vertices) + " vertices";
      }
      break;
    }
  return line == 0 ? std::string() : "line " + std::to_string(line) + ": " + what;
}

void add_summary_warnings(const std::string& path, const ObjSummary& summary, Scene& scene) {
  auto& report = scene.report;
  if (const auto first = first_bad_vertex_reference(summary); !first.empty())
    report.warnings.push_back(path + ": " + first);
  if (summary.short_faces > 0)
    report.warnings.push_back(path + ": skipped " + std::to_string(summary.short_faces) +
                              " faces with fewer than 3 vertices (first at line " +
                              std::to_string(summary.first_short_face_line) + ")");
  report.unknown_statements = summary.unknown_statements;
  if (summary.unknown_statements > 0)
    report.warnings.push_back(path + ": skipped " + std::to_string(summary.unknown_statements) +
                              " unknown statements (first: '" + summary.first_unknown +
                              "' at line " + std::to_string(summary.first_unknown_line) + ")");
}

// Both passes only read `text`, so the pre-scan runs beside tinyobjloader (it takes about a
// second of the Crown's 141 MB). A pre-scan error wins: it names the line more precisely.
ObjSummary parse_in_parallel(const std::string& path, std::string& text, tinyobj::attrib_t& attrib,
                             std::vector<tinyobj::shape_t>& shapes) {
  ObjSummary summary;
  std::exception_ptr prescan_error;
  const auto run_prescan = [&] {
    try {
      summary = ObjPrescan(path).run(text);
    } catch (...) {
      prescan_error = std::current_exception();
    }
  };
  std::thread prescan;
  try {
    prescan = std::thread(run_prescan);
  } catch (const std::system_error&) {  // no thread to be had: scan first instead
    run_prescan();
  }
  std::exception_ptr tinyobj_error;
  try {
    run_tinyobj(path, text, attrib, shapes);
  } catch (...) {
    tinyobj_error = std::current_exception();
  }
  if (prescan.joinable()) prescan.join();
  if (prescan_error) std::rethrow_exception(prescan_error);
  check_limits(path, summary);
  if (tinyobj_error) std::rethrow_exception(tinyobj_error);
  return summary;
}

/// Rewrites what both parsers would misread into what they read alike, in place: a UTF-8 byte
/// order mark (tinyobjloader took it for part of the first keyword and dropped that vertex,
/// shifting every face), comments after a statement ("v 1 2 3 # note", rejected before), and
/// lines continued with a backslash (joined). Comments are blanked first, so a comment that
/// ends in a backslash does not swallow the next line. Joined lines make messages name the
/// first line of a statement, counted as if the file had no continuations.
void normalise_obj_text(std::string& text) {
  if (text.starts_with("\xEF\xBB\xBF")) text.erase(0, 3);
  if (text.find_first_of("#\\") == std::string::npos) return;
  bool in_comment = false;
  for (char& c : text) {
    if (c == '\n' || c == '\r')
      in_comment = false;
    else if (c == '#')
      in_comment = true;
    if (in_comment) c = ' ';
  }
  std::size_t out = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\\') {
      std::size_t next = i + 1;
      while (next < text.size() && (text[next] == ' ' || text[next] == '\t'))
        ++next;  // trailing blanks after the backslash
      if (next < text.size() && (text[next] == '\n' || text[next] == '\r')) {
        if (text[next] == '\r' && next + 1 < text.size() && text[next + 1] == '\n') ++next;
        text[out++] = ' ';
        i = next;
        continue;
      }
    }
    text[out++] = text[i];
  }
  text.resize(out);
}

}  // namespace

// Reads an OBJ file (optionally .gz/.xz). Invalid triangles are kept; load_scene drops them.
Scene load_obj_file(const std::string& path) {
  std::string text = read_file_decompressed(path);
  normalise_obj_text(text);
  Scene scene;
  ObjSummary summary;
  {  // tinyobjloader's arrays go out of scope once copied
    tinyobj::attrib_t attrib;
    std::vector<tinyobj::shape_t> shapes;
    summary = parse_in_parallel(path, text, attrib, shapes);
    std::string().swap(text);  // free the text before building the scene's arrays
    copy_vertices(path, summary, attrib, scene);
    copy_triangles(path, summary, shapes, scene);
  }
  scene.report.vertices_read = scene.vertices.size();
  scene.report.triangles_read = scene.triangles.size();
  add_summary_warnings(path, summary, scene);
  return scene;
}

}  // namespace irgrid::detail
