// irgrid/error.h: the one exception type the library throws, with a short code.
#pragma once

#include <stdexcept>
#include <string>

namespace irgrid {

/// Short classification of an error; the message carries the details (file, line, value).
enum class ErrorCode {
  invalid_argument,  ///< a caller passed a value outside the documented range
  io,                ///< a file is missing, unreadable or malformed
  out_of_memory,     ///< host or device memory could not be allocated
  no_device,         ///< a CUDA backend was asked for but no usable GPU is visible
  limit_exceeded,    ///< a count or resolution would overflow a documented limit
  internal,          ///< an internal invariant failed: a bug in irgrid
};

/// Name of a code as printed in messages, e.g. "io".
const char* to_string(ErrorCode code) noexcept;

/// Every error the library reports. The library never calls exit() and never prints.
class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ErrorCode code() const noexcept { return code_; }

 private:
  ErrorCode code_;
};

}  // namespace irgrid
