// parse_double (preprocess/readers/decimal.h) must return exactly what std::from_chars returns:
// the same bits, the same end pointer and the same error, for the tokens that take Clinger's
// fast path, for those at its edges (2^53, 10^22, 19 digits) and for everything it hands on.
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "readers/decimal.h"

namespace {

// Compares parse_double and std::from_chars on s; returns true when parse_double's result is
// the fast path's (for the coverage checks), i.e. it did not defer to from_chars.
void expect_same(const std::string& s) {
  double a = 12345.0, b = 12345.0;  // same sentinel: on error neither may write
  const char* first = s.data();
  const char* last = s.data() + s.size();
  const auto ra = mds::parse_double(first, last, a);
  const auto rb = std::from_chars(first, last, b);
  ASSERT_EQ(ra.ec, rb.ec) << "'" << s << "'";
  ASSERT_EQ(ra.ptr - first, rb.ptr - first) << "'" << s << "'";
  ASSERT_EQ(std::bit_cast<uint64_t>(a), std::bit_cast<uint64_t>(b))
      << "'" << s << "': " << a << " vs " << b;
}

TEST(ParseDouble, TypicalDumpTokens) {
  for (const char* s : {"0", "1", "-1", "0.5140", "1.8467", "-3.3837", "12.000000", "0.0001", "1e-05",
                        "1.2345e-05", "-2.5E+03", "6.02214076e23", "3.14159265358979", "-0", "-0.0", "0.0",
                        "100", "1.", ".5", "-.5", "1.5e5", "1.5e05", "7E2"})
    expect_same(s);
}

TEST(ParseDouble, EdgesOfTheFastPath) {
  // m = 2^53 is exact; 2^53 + 1 is not a double and must round like from_chars.
  for (const char* s : {"9007199254740992", "9007199254740993", "9007199254740994", "900719925474099.3",
                        "9007199254740993e-5", "9999999999999999999", "99999999999999999999", "1234567890123456789",
                        "0.1234567890123456789", "1e22", "1e23", "1e-22", "1e-23", "4.9e-324", "2.2250738585072014e-308",
                        "1.7976931348623157e308", "1.8e308", "1e-400", "0e500", "0.0000000000000000000000001",
                        "123456789012345678901234567890"})
    expect_same(s);
}

TEST(ParseDouble, WhatItHandsOnKeepsFromCharsErrors) {
  for (const char* s : {"", "-", ".", "-.", "e5", "1e", "1e+", "1e-", "1e+x", "inf", "-inf", "nan", "infinity",
                        "+1", "abc", "1..2", "1.2.3", "0x10", "1e99999999999", "--1", "1-2", " 1", "1 2"})
    expect_same(s);
}

TEST(ParseDouble, StopsWhereFromCharsStops) {
  // Tokens are followed by blanks and newlines in a dump; both parsers must stop there.
  for (const char* s : {"1.25 7", "1.25\n", "-0.5\t3", "3e2 ", "1.5x", "2.5e", "2.5e+", "7E-3\r\n"}) expect_same(s);
}

TEST(ParseDouble, RandomTokensOfEveryShape) {
  std::mt19937_64 rng(20261125);
  std::uniform_int_distribution<int> ndig(0, 24), coin(0, 1), edig(0, 3), digit(0, 9);
  std::uniform_int_distribution<int> shape(0, 9);
  for (int i = 0; i < 200000; ++i) {
    std::string s;
    if (coin(rng)) s += '-';
    const int a = ndig(rng), b = ndig(rng);
    for (int k = 0; k < a; ++k) s += char('0' + digit(rng));
    if (shape(rng) < 8) {
      s += '.';
      for (int k = 0; k < b % 12; ++k) s += char('0' + digit(rng));
    }
    if (shape(rng) < 3) {
      s += coin(rng) ? 'e' : 'E';
      const int sg = shape(rng);
      if (sg < 3) s += '-';
      else if (sg < 5) s += '+';
      for (int k = 0, n = edig(rng); k < n; ++k) s += char('0' + digit(rng));
    }
    if (shape(rng) < 2) s += " 1";
    expect_same(s);
    if (HasFatalFailure()) return;
  }
}

TEST(ParseDouble, RandomDoublesPrintedLikeDumps) {
  // Values printed with %g, %.Nf and %.17g round-trip through both parsers identically.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e4, 1e4);
  std::uniform_int_distribution<int> prec(1, 17), ex(-30, 30);
  char buf[64];
  for (int i = 0; i < 100000; ++i) {
    const double v = u(rng) * std::pow(10.0, ex(rng) / 3);
    const int p = prec(rng);
    std::snprintf(buf, sizeof buf, "%.*g", p, v);
    expect_same(buf);
    std::snprintf(buf, sizeof buf, "%.*f", p % 9, v);
    expect_same(buf);
    std::snprintf(buf, sizeof buf, "%.17g", v);
    expect_same(buf);
    if (HasFatalFailure()) return;
  }
}

}  // namespace
