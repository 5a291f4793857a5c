// Decimal-to-double parsing for the text readers' hot loop: Clinger's fast path (W. D. Clinger,
// "How to Read Floating Point Numbers Accurately", PLDI 1990, §3) in front of std::from_chars.
//
// A token "[-]digits[.digits][(e|E)[+|-]digits]" whose digits form an integer m <= 2^53 and
// whose decimal exponent q satisfies |q| <= 22 is m * 10^q or m / 10^-q: m and 10^|q| are both
// exact doubles, so one IEEE multiplication or division gives the correctly rounded value, the
// same double that std::from_chars returns. Dumps written with "%g" or a fixed number of
// decimals (LAMMPS, XYZ) almost always take this path; every other token (more digits, larger
// exponents, inf/nan, malformed text) goes to std::from_chars, so results and errors are those
// of std::from_chars for every input (tests/test_decimal.cpp compares them bit for bit).
#pragma once

#include <charconv>
#include <cstdint>

namespace mds {

namespace decimal_detail {
inline constexpr double kPow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                      1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
inline constexpr uint64_t kMaxExactMantissa = uint64_t(1) << 53;  // every integer up to 2^53 is a double
inline bool is_digit(char c) { return static_cast<unsigned char>(c - '0') < 10; }
}  // namespace decimal_detail

// Same contract as std::from_chars(first, last, value) with chars_format::general.
inline std::from_chars_result parse_double(const char* first, const char* last, double& value) {
  using namespace decimal_detail;
  const char* p = first;
  const bool negative = p < last && *p == '-';
  if (negative) ++p;
  uint64_t m = 0;
  int digits = 0;       // digits read into m (leading zeros included; at most 19 keeps m exact in 64 bits)
  int fraction = 0;     // digits after the point
  while (p < last && is_digit(*p)) {
    m = m * 10 + uint64_t(*p - '0');
    ++p;
    ++digits;
  }
  if (p < last && *p == '.') {
    ++p;
    while (p < last && is_digit(*p)) {
      m = m * 10 + uint64_t(*p - '0');
      ++p;
      ++digits;
      ++fraction;
    }
  }
  if (digits == 0 || digits > 19 || m > kMaxExactMantissa) return std::from_chars(first, last, value);
  int q = -fraction;
  if (p < last && (*p == 'e' || *p == 'E')) {
    const char* e = p + 1;
    bool eneg = false;
    if (e < last && (*e == '+' || *e == '-')) eneg = *e++ == '-';
    if (e == last || !is_digit(*e)) return std::from_chars(first, last, value);  // "1e", "1e+": from_chars decides
    int x = 0;
    while (e < last && is_digit(*e)) {
      if (x > 1000) return std::from_chars(first, last, value);  // absurd exponent: not the fast path
      x = x * 10 + (*e - '0');
      ++e;
    }
    q += eneg ? -x : x;
    p = e;
  }
  if (q < -22 || q > 22) return std::from_chars(first, last, value);
  double v = static_cast<double>(m);
  v = q < 0 ? v / kPow10[-q] : v * kPow10[q];
  value = negative ? -v : v;
  return {p, std::errc()};
}

}  // namespace mds
