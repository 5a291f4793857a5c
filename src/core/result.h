// Errors as values. Library code returns Result<T> / Status; only the CLI prints and exits.
//
// Every message names the file and the place (line, dataset, byte offset) where that is
// known, e.g. "dump.lammpstrj:1207: expected 5 columns, found 4".
#pragma once

#include <cassert>
#include <optional>
#include <string>
#include <utility>
#include <variant>

#include <fmt/format.h>

namespace mds {

enum class Errc {
  io,               // open/read/write/rename failed
  format,           // malformed input: bad syntax, bad magic, wrong shape
  range,            // value out of range: NaN/Inf, absurd count, offset outside the file
  checksum,         // stored checksum does not match the data
  unsupported,      // valid but not supported (format version, vertex type, ...)
  invalid_argument, // caller/user passed a bad option
  budget,           // a memory or GPU budget is too small for the request
  internal,         // a broken invariant in mdstream itself
};

const char* errc_name(Errc c);

struct Error {
  Errc code = Errc::internal;
  std::string message;
};

template <class... Args>
Error make_error(Errc code, fmt::format_string<Args...> f, Args&&... args) {
  return Error{code, fmt::format(f, std::forward<Args>(args)...)};
}

// Result<T>: either a value or an Error. Minimal std::expected stand-in (C++20).
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}          // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}      // NOLINT(google-explicit-constructor)

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & { assert(ok()); return std::get<0>(v_); }
  const T& value() const& { assert(ok()); return std::get<0>(v_); }
  T&& value() && { assert(ok()); return std::get<0>(std::move(v_)); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  const Error& error() const { assert(!ok()); return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

// Status: success or an Error.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : e_(std::move(error)) {}  // NOLINT(google-explicit-constructor)
  static Status success() { return {}; }
  bool ok() const { return !e_.has_value(); }
  explicit operator bool() const { return ok(); }
  const Error& error() const { assert(!ok()); return *e_; }

 private:
  std::optional<Error> e_;
};

}  // namespace mds

// Propagate an error from a Status/Result expression.
#define MDS_TRY(expr)                                   \
  do {                                                  \
    auto&& mds_try_r_ = (expr);                         \
    if (!mds_try_r_.ok()) return mds_try_r_.error();    \
  } while (0)

// Assign the value of a Result expression to `lhs`, or propagate its error.
#define MDS_CONCAT_INNER_(a, b) a##b
#define MDS_CONCAT_(a, b) MDS_CONCAT_INNER_(a, b)
#define MDS_ASSIGN_OR_RETURN(lhs, expr) MDS_ASSIGN_OR_RETURN_IMPL_(MDS_CONCAT_(mds_r_, __LINE__), lhs, expr)
#define MDS_ASSIGN_OR_RETURN_IMPL_(tmp, lhs, expr) \
  auto tmp = (expr);                               \
  if (!tmp.ok()) return tmp.error();               \
  lhs = std::move(tmp).value()
