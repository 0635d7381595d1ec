// Names of error codes.
#include "irgrid/error.h"

namespace irgrid {

const char* to_string(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::invalid_argument:
      return "invalid argument";
    case ErrorCode::io:
      return "io";
    case ErrorCode::out_of_memory:
      return "out of memory";
    case ErrorCode::no_device:
      return "no device";
    case ErrorCode::limit_exceeded:
      return "limit exceeded";
    case ErrorCode::internal:
      return "internal";
  }
  return "unknown";
}

}  // namespace irgrid
