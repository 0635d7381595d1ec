// PLY loader (ascii, binary little and big endian): vertex x/y/z and face index lists.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/number_text.h"
#include "irgrid/error.h"
#include "irgrid/io/scene.h"

namespace irgrid::detail {
namespace {

constexpr std::uint32_t kInvalidIndex = 0xFFFFFFFFu;
constexpr std::uint64_t kMaxCount = 0xFFFFFFFEull;  // 2^32-2: uint32 ids stay below the sentinel

enum class PlyType { int8, uint8, int16, uint16, int32, uint32, float32, float64 };
enum class PlyFormat { ascii, binary_little_endian, binary_big_endian };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::float32;  // the item type for a list
  bool is_list = false;
  PlyType count_type = PlyType::uint8;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::ascii;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;
  std::uint64_t body_first_line = 0;  // line number of the first body line (ascii errors)
};

std::size_t type_size(PlyType type) {
  switch (type) {
    case PlyType::int8:
    case PlyType::uint8:
      return 1;
    case PlyType::int16:
    case PlyType::uint16:
      return 2;
    case PlyType::int32:
    case PlyType::uint32:
    case PlyType::float32:
      return 4;
    case PlyType::float64:
      return 8;
  }
  return 0;
}

bool is_integer_type(PlyType type) {
  return type != PlyType::float32 && type != PlyType::float64;
}

bool parse_type(std::string_view name, PlyType& type) {
  struct Named {
    std::string_view name;
    PlyType type;
  };
  static constexpr Named kTypes[] = {
      {"char", PlyType::int8},      {"int8", PlyType::int8},       {"uchar", PlyType::uint8},
      {"uint8", PlyType::uint8},    {"short", PlyType::int16},     {"int16", PlyType::int16},
      {"ushort", PlyType::uint16},  {"uint16", PlyType::uint16},   {"int", PlyType::int32},
      {"int32", PlyType::int32},    {"uint", PlyType::uint32},     {"uint32", PlyType::uint32},
      {"float", PlyType::float32},  {"float32", PlyType::float32}, {"double", PlyType::float64},
      {"float64", PlyType::float64}};
  for (const auto& named : kTypes)
    if (named.name == name) {
      type = named.type;
      return true;
    }
  return false;
}

bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_blank(line[i]))
      ++i;
    const std::size_t begin = i;
    while (i < line.size() && !is_blank(line[i]))
      ++i;
    if (i > begin) words.push_back(line.substr(begin, i - begin));
  }
  return words;
}

// Parses the header line by line; `line` is the 1-based number for messages.
class HeaderParser {
 public:
  HeaderParser(const std::string& path, std::vector<std::string>& warnings)
      : path_(path), warnings_(warnings) {}
  PlyHeader parse(std::string_view text);

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(ErrorCode::io, path_ + ": line " + std::to_string(line_) + ": " + what);
  }
  void parse_format(const std::vector<std::string_view>& words);
  void parse_element(const std::vector<std::string_view>& words);
  void parse_property(const std::vector<std::string_view>& words);
  PlyType type_named(std::string_view name) const;

  const std::string& path_;
  std::vector<std::string>& warnings_;
  std::uint64_t line_ = 0;
  bool have_format_ = false;
  PlyHeader header_;
};

PlyType HeaderParser::type_named(std::string_view name) const {
  PlyType type;
  if (!parse_type(name, type)) fail("unknown PLY property type '" + std::string(name) + "'");
  return type;
}

void HeaderParser::parse_format(const std::vector<std::string_view>& words) {
  if (words.size() < 2) fail("format line without a format");
  if (words[1] == "ascii")
    header_.format = PlyFormat::ascii;
  else if (words[1] == "binary_little_endian")
    header_.format = PlyFormat::binary_little_endian;
  else if (words[1] == "binary_big_endian")
    header_.format = PlyFormat::binary_big_endian;
  else
    fail("unknown PLY format '" + std::string(words[1]) + "'");
  have_format_ = true;
}

void HeaderParser::parse_element(const std::vector<std::string_view>& words) {
  if (words.size() != 3) fail("expected 'element NAME COUNT'");
  PlyElement element;
  element.name = std::string(words[1]);
  const auto [end, ec] =
      std::from_chars(words[2].data(), words[2].data() + words[2].size(), element.count);
  if (ec != std::errc() || end != words[2].data() + words[2].size())
    fail("bad element count '" + std::string(words[2]) + "'");
  header_.elements.push_back(std::move(element));
}

void HeaderParser::parse_property(const std::vector<std::string_view>& words) {
  if (header_.elements.empty()) fail("property before any element");
  PlyProperty property;
  if (words.size() == 5 && words[1] == "list") {
    property.is_list = true;
    property.count_type = type_named(words[2]);
    property.type = type_named(words[3]);
    property.name = std::string(words[4]);
    if (!is_integer_type(property.count_type)) fail("list count type must be an integer type");
  } else if (words.size() == 3) {
    property.type = type_named(words[1]);
    property.name = std::string(words[2]);
  } else {
    fail("expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'");
  }
  header_.elements.back().properties.push_back(std::move(property));
}

PlyHeader HeaderParser::parse(std::string_view text) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t newline = text.find('\n', pos);
    const std::size_t end = newline == std::string_view::npos ? text.size() : newline;
    const auto words = split_words(text.substr(pos, end - pos));
    pos = end + 1;
    ++line_;
    if (line_ == 1) {
      if (words.size() != 1 || words[0] != "ply") fail("not a PLY file (no 'ply' magic line)");
      continue;
    }
    if (words.empty() || words[0] == "comment" || words[0] == "obj_info") continue;
    if (words[0] == "end_header") {
      if (!have_format_) fail("PLY header has no format line");
      header_.body_offset = std::min(pos, text.size());
      header_.body_first_line = line_ + 1;
      return std::move(header_);
    }
    if (words[0] == "format")
      parse_format(words);
    else if (words[0] == "element")
      parse_element(words);
    else if (words[0] == "property")
      parse_property(words);
    else
      warnings_.push_back(path_ + ": line " + std::to_string(line_) +
                          ": ignored unknown PLY header line '" + std::string(words[0]) + "'");
  }
  throw Error(ErrorCode::io, path_ + ": PLY header not terminated by end_header");
}

// Where in the body we are, for error messages.
struct ReadContext {
  const std::string* path = nullptr;
  const PlyElement* element = nullptr;
  std::uint64_t record = 0;
  std::string where() const {
    return "element '" + element->name + "' (record " + std::to_string(record + 1) + " of " +
           std::to_string(element->count) + ")";
  }
};

template <typename T>
T load_swapped(const char* bytes, bool swap) {
  using Bits = std::conditional_t<
      sizeof(T) == 1, std::uint8_t,
      std::conditional_t<sizeof(T) == 2, std::uint16_t,
                         std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>>;
  Bits bits;
  std::memcpy(&bits, bytes, sizeof bits);
  if (swap) {
    if constexpr (sizeof(T) == 2) bits = __builtin_bswap16(bits);
    if constexpr (sizeof(T) == 4) bits = __builtin_bswap32(bits);
    if constexpr (sizeof(T) == 8) bits = __builtin_bswap64(bits);
  }
  return std::bit_cast<T>(bits);
}

// Reads binary values of either byte order from the body.
class BinaryCursor {
 public:
  BinaryCursor(std::string_view body, bool big_endian, const ReadContext& context)
      : pos_(body.data()),
        end_(body.data() + body.size()),
        swap_(big_endian != (std::endian::native == std::endian::big)),
        context_(context) {}

  double number(PlyType type) {
    const char* bytes = take(type_size(type));
    switch (type) {
      case PlyType::int8:
        return load_swapped<std::int8_t>(bytes, swap_);
      case PlyType::uint8:
        return load_swapped<std::uint8_t>(bytes, swap_);
      case PlyType::int16:
        return load_swapped<std::int16_t>(bytes, swap_);
      case PlyType::uint16:
        return load_swapped<std::uint16_t>(bytes, swap_);
      case PlyType::int32:
        return load_swapped<std::int32_t>(bytes, swap_);
      case PlyType::uint32:
        return load_swapped<std::uint32_t>(bytes, swap_);
      case PlyType::float32:
        return load_swapped<float>(bytes, swap_);
      case PlyType::float64:
        return load_swapped<double>(bytes, swap_);
    }
    return 0;
  }
  void skip(PlyType type) { take(type_size(type)); }
  void skip(PlyType type, std::uint64_t count) {
    if (count > std::uint64_t(end_ - pos_) / type_size(type)) truncated();
    pos_ += count * type_size(type);
  }

 private:
  [[noreturn]] void truncated() const {
    throw Error(ErrorCode::io, *context_.path + ": truncated binary data in " + context_.where());
  }
  const char* take(std::size_t size) {
    if (std::size_t(end_ - pos_) < size) truncated();
    const char* bytes = pos_;
    pos_ += size;
    return bytes;
  }

  const char* pos_;
  const char* end_;
  bool swap_;
  const ReadContext& context_;
};

// Reads whitespace-separated ascii values, counting lines for messages.
class AsciiCursor {
 public:
  AsciiCursor(std::string_view body, std::uint64_t first_line, const ReadContext& context)
      : text_(body), line_(first_line), context_(context) {}

  double number(PlyType type) {
    std::string_view token = next_token();
    if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
    double value = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (end != token.data() + token.size()) fail("malformed number", token);
    if (ec == std::errc::result_out_of_range)
      value = std::strtod(std::string(token).c_str(), nullptr);
    else if (ec != std::errc())
      fail("malformed number", token);
    if (is_integer_type(type) && value != std::floor(value)) fail("expected an integer", token);
    return value;
  }
  void skip(PlyType type) { number(type); }
  void skip(PlyType type, std::uint64_t count) {
    for (std::uint64_t i = 0; i < count; ++i)
      number(type);
  }

 private:
  [[noreturn]] void fail(const char* what, std::string_view token) const {
    const std::string quoted = token.empty() ? "" : " '" + std::string(token.substr(0, 40)) + "'";
    throw Error(ErrorCode::io, *context_.path + ": line " + std::to_string(line_) + ": " + what +
                                   quoted + " in " + context_.where());
  }
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }
  std::string_view next_token() {
    while (pos_ < text_.size() && is_space(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= text_.size()) {
      line_ = last_token_line_;  // the line that ended too early, not the empty one after it
      fail("unexpected end of file", "");
    }
    last_token_line_ = line_;
    const std::size_t begin = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_]))
      ++pos_;
    return text_.substr(begin, pos_ - begin);
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  std::uint64_t line_;
  std::uint64_t last_token_line_ = line_;
  const ReadContext& context_;
};

int property_index(const PlyElement& element, std::string_view name) {
  for (std::size_t i = 0; i < element.properties.size(); ++i)
    if (element.properties[i].name == name) return int(i);
  return -1;
}

// The loader's state while reading the body.
class PlyBodyReader {
 public:
  PlyBodyReader(const std::string& path, Scene& scene, std::size_t body_size, bool ascii)
      : path_(path), scene_(scene), body_size_(body_size), ascii_(ascii) {}
  template <typename Cursor>
  void read(const PlyHeader& header, Cursor& cursor, ReadContext& context);
  std::uint64_t short_faces = 0;
  /// The first face record (counting from 0) with an out-of-range vertex index, that index, and
  /// the vertex count the header declares; first_bad_face is -1 when every index is in range.
  std::int64_t first_bad_face = -1;
  double first_bad_index = 0;
  std::uint64_t declared_vertices = 0;

 private:
  template <typename Cursor>
  void read_vertices(const PlyElement& element, Cursor& cursor, ReadContext& context);
  template <typename Cursor>
  void read_faces(const PlyElement& element, Cursor& cursor, ReadContext& context);
  template <typename Cursor>
  void skip_element(const PlyElement& element, Cursor& cursor, ReadContext& context);
  template <typename Cursor>
  void skip_property(const PlyProperty& property, Cursor& cursor, const ReadContext& context);
  template <typename Cursor>
  std::uint64_t list_length(const PlyProperty& property, Cursor& cursor,
                            const ReadContext& context);
  void add_face(const std::vector<std::uint32_t>& face);
  std::uint64_t records_to_reserve(const PlyElement& element) const;

  const std::string& path_;
  Scene& scene_;
  std::size_t body_size_;
  bool ascii_;
};

// The count comes from the file: never reserve more records than the body could hold.
std::uint64_t PlyBodyReader::records_to_reserve(const PlyElement& element) const {
  std::uint64_t min_bytes = 0;  // a record's smallest size: empty lists, 1-digit ascii values
  for (const auto& property : element.properties)
    min_bytes += ascii_ ? 2 : type_size(property.is_list ? property.count_type : property.type);
  return std::min<std::uint64_t>(element.count, body_size_ / std::max<std::uint64_t>(min_bytes, 1));
}

template <typename Cursor>
std::uint64_t PlyBodyReader::list_length(const PlyProperty& property, Cursor& cursor,
                                         const ReadContext& context) {
  const double count = cursor.number(property.count_type);
  // Every item takes at least one byte, so a longer list cannot be real data.
  if (!(count >= 0 && count <= double(body_size_)))
    throw Error(ErrorCode::io,
                path_ + ": invalid list length " + number_text(count) + " in " + context.where());
  return std::uint64_t(count);
}

template <typename Cursor>
void PlyBodyReader::skip_property(const PlyProperty& property, Cursor& cursor,
                                  const ReadContext& context) {
  if (!property.is_list) return cursor.skip(property.type);
  cursor.skip(property.type, list_length(property, cursor, context));
}

template <typename Cursor>
void PlyBodyReader::skip_element(const PlyElement& element, Cursor& cursor, ReadContext& context) {
  // Records without properties take no bytes: a count of 10^17 must not spin through them.
  if (element.properties.empty()) return;
  for (context.record = 0; context.record < element.count; ++context.record)
    for (const auto& property : element.properties)
      skip_property(property, cursor, context);
}

template <typename Cursor>
void PlyBodyReader::read_vertices(const PlyElement& element, Cursor& cursor, ReadContext& context) {
  const int axes[3] = {property_index(element, "x"), property_index(element, "y"),
                       property_index(element, "z")};
  for (int axis : axes)
    if (axis < 0 || element.properties[axis].is_list)
      throw Error(ErrorCode::io, path_ + ": PLY vertex element lacks scalar x, y and z properties");
  if (element.count > kMaxCount - scene_.vertices.size())
    throw Error(ErrorCode::limit_exceeded, path_ + ": " + std::to_string(element.count) +
                                               " vertices exceed the limit of 2^32-2");
  scene_.vertices.reserve(scene_.vertices.size() + records_to_reserve(element));
  for (context.record = 0; context.record < element.count; ++context.record) {
    Vec3f position{};
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const auto& property = element.properties[p];
      const int axis = int(p) == axes[0] ? 0 : int(p) == axes[1] ? 1 : int(p) == axes[2] ? 2 : -1;
      if (axis < 0)
        skip_property(property, cursor, context);
      else
        position[axis] = float(cursor.number(property.type));
    }
    scene_.vertices.push_back(position);
  }
}

void PlyBodyReader::add_face(const std::vector<std::uint32_t>& face) {
  if (face.size() < 3) {
    ++short_faces;
    return;
  }
  if (scene_.triangles.size() + face.size() - 2 > kMaxCount)
    throw Error(ErrorCode::limit_exceeded, path_ + ": more than 2^32-2 triangles (limit exceeded)");
  for (std::size_t k = 1; k + 1 < face.size(); ++k)  // a fan from the first vertex
    scene_.triangles.push_back({face[0], face[k], face[k + 1]});
}

template <typename Cursor>
void PlyBodyReader::read_faces(const PlyElement& element, Cursor& cursor, ReadContext& context) {
  int list = property_index(element, "vertex_indices");
  if (list < 0) list = property_index(element, "vertex_index");
  if (list < 0 || !element.properties[list].is_list)
    throw Error(ErrorCode::io, path_ + ": PLY face element has no vertex_indices list");
  scene_.triangles.reserve(scene_.triangles.size() + records_to_reserve(element));
  std::vector<std::uint32_t> face;
  for (context.record = 0; context.record < element.count; ++context.record) {
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const auto& property = element.properties[p];
      if (int(p) != list) {
        skip_property(property, cursor, context);
        continue;
      }
      const std::uint64_t count = list_length(property, cursor, context);
      face.clear();
      for (std::uint64_t i = 0; i < count; ++i) {
        const double index = cursor.number(property.type);
        // A float list may hold 2.5: no vertex, not vertex 2.
        const bool whole = index == std::floor(index);
        if (!(whole && index >= 0 && index < double(declared_vertices)) && first_bad_face < 0)
          first_bad_face = std::int64_t(context.record), first_bad_index = index;
        // Negative, fractional or too large: an invalid value that drop_invalid_triangles counts.
        face.push_back(whole && index >= 0 && index <= double(kMaxCount) ? std::uint32_t(index)
                                                                         : kInvalidIndex);
      }
    }
    add_face(face);
  }
}

template <typename Cursor>
void PlyBodyReader::read(const PlyHeader& header, Cursor& cursor, ReadContext& context) {
  bool have_vertices = false, have_faces = false;
  for (const auto& element : header.elements)
    if (element.name == "vertex") {
      declared_vertices = element.count;
      break;
    }
  for (const auto& element : header.elements) {
    context.element = &element;
    if (element.name == "vertex" && !have_vertices) {
      read_vertices(element, cursor, context);
      have_vertices = true;
    } else if (element.name == "face" && !have_faces) {
      read_faces(element, cursor, context);
      have_faces = true;
    } else {
      skip_element(element, cursor, context);
    }
  }
  if (!have_vertices) throw Error(ErrorCode::io, path_ + ": PLY file has no vertex element");
  if (!have_faces) scene_.report.warnings.push_back(path_ + ": PLY file has no face element");
}

// An index as the file wrote it: whole numbers in full, others (float lists) as %.7g.
std::string index_text(double index) {
  return index == std::floor(index) && std::fabs(index) < 0x1p53
             ? std::to_string(std::int64_t(index))
             : number_text(index);
}

}  // namespace

// Reads a PLY file (optionally .gz/.xz). Invalid triangles are kept; load_scene drops them.
Scene load_ply_file(const std::string& path) {
  const std::string text = read_file_decompressed(path);
  Scene scene;
  const PlyHeader header = HeaderParser(path, scene.report.warnings).parse(text);
  const std::string_view body = std::string_view(text).substr(header.body_offset);
  ReadContext context;
  context.path = &path;
  PlyBodyReader reader(path, scene, body.size(), header.format == PlyFormat::ascii);
  if (header.format == PlyFormat::ascii) {
    AsciiCursor cursor(body, header.body_first_line, context);
    reader.read(header, cursor, context);
  } else {
    BinaryCursor cursor(body, header.format == PlyFormat::binary_big_endian, context);
    reader.read(header, cursor, context);
  }
  scene.report.vertices_read = scene.vertices.size();
  scene.report.triangles_read = scene.triangles.size();
  if (reader.short_faces > 0)
    scene.report.warnings.push_back(path + ": skipped " + std::to_string(reader.short_faces) +
                                    " faces with fewer than 3 vertices");
  if (reader.first_bad_face >= 0)
    scene.report.warnings.push_back(
        path + ": face " + std::to_string(reader.first_bad_face) +
        " (counting from 0): vertex index " + index_text(reader.first_bad_index) +
        (reader.first_bad_index == std::floor(reader.first_bad_index)
             ? " is not below the file's " + std::to_string(reader.declared_vertices) + " vertices"
             : " is not a whole number"));
  return scene;
}

}  // namespace irgrid::detail
