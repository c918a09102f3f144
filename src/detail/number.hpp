// Number parsing shared by the file readers and the command line: locale-independent (fast_float,
// correctly rounded; std::stod and strtod follow LC_NUMERIC, so "1.5" fails under a German locale)
// and strict about the whole text. Also the short forms of numbers in the pipelines' messages and
// warnings (number, fixed).
#pragma once

#include <fast_float/fast_float.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>

namespace align3d::detail {

// fast_float reads "nan" and "inf" (the readers count and drop such points) but, like
// std::from_chars by design, rejects a leading '+', which some exporters and users write.
inline const char* skip_plus(const char* first, const char* last) {
  return (last - first > 1 && first[0] == '+' && first[1] != '-') ? first + 1 : first;
}

// True if all of `text` is one number (decimal or scientific, "nan" and "inf" included).
inline bool parse_number(std::string_view text, double& value) {
  const char* last = text.data() + text.size();
  const auto result = fast_float::from_chars(skip_plus(text.data(), last), last, value);
  return !text.empty() && result.ec == std::errc() && result.ptr == last;
}

// A finite number, surrounding spaces and tabs allowed ("0, 0, 1" on a command line); nullopt for
// anything else: "", "1x", "nan", "inf", "1e999" (out of range).
inline std::optional<double> parse_finite(std::string_view text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string_view::npos) return std::nullopt;
  text = text.substr(first, text.find_last_not_of(" \t") + 1 - first);
  double value = 0.0;
  if (!parse_number(text, value) || !std::isfinite(value)) return std::nullopt;
  return value;
}

// `value` to `significant_digits` digits, for a message (printf's %g: "0.0123", "1.5e+03").
inline std::string number(double value, int significant_digits = 3) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", significant_digits, value);
  return buffer;
}

// `value` with `decimals` digits after the point, for a message (printf's %f: "12.50").
inline std::string fixed(double value, int decimals = 2) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

}  // namespace align3d::detail
