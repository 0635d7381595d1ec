// core/number_text.h: numbers as error messages print them.
#pragma once

#include <cstdio>
#include <string>

namespace irgrid {

/// `value` with up to 7 significant digits ("1e+30", "0.12", "nan"): std::to_string prints a
/// float of 1e30 as 31 digits and 6 decimals, and a tiny one as 0.000000.
inline std::string number_text(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.7g", value);
  return text;
}

}  // namespace irgrid
