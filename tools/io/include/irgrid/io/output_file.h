// irgrid/io/output_file.h: writing an output file whole or not at all.
#pragma once

#include <string>
#include <string_view>

namespace irgrid {

/// Writes `bytes` to `path`: into a temporary file beside it, flushed and closed with every
/// call checked, then renamed over `path`, so that a full disk or an interrupted command never
/// leaves a truncated file under the final name. A path that is not a regular file (/dev/null,
/// /dev/full, a pipe) is written in place, with every write checked. Throws Error{io} naming
/// the path and the system's reason. `bytes` may hold any bytes, text or binary.
void write_file_whole(const std::string& path, std::string_view bytes);

}  // namespace irgrid
