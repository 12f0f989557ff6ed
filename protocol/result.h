// Result<T>: the one error type on every decode, I/O and network path in Loam.
//
// GCC 12 has std::expected only under C++23 and clang 14 not at all, so this is a small
// in-house equivalent. An Error carries a machine-readable code, the field or file it was
// about, and a human sentence. Functions that can fail on untrusted input return Result;
// they never throw.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace loam {

enum class ErrorCode : unsigned char {
  kInvalidArgument,  // a parameter is out of its documented range
  kNotFinite,        // NaN or infinity where a finite number is required
  kTruncated,        // input ended before a field was complete
  kOversize,         // a length or count exceeds its cap
  kBadEnum,          // an enumerator outside the known set
  kUnknownType,      // an unknown message or record type
  kUnsupported,      // a valid but unsupported format, version or feature
  kCorrupt,          // checksum or consistency check failed
  kIo,               // the operating system refused a read or write
  kNotFound,         // a file, tile or id does not exist
  kUnauthorized,     // the caller's role does not allow the operation
  kBusy,             // the peer is at capacity (server full, rate limited, too many pending): retry later
};

const char* to_string(ErrorCode code);

struct Error {
  ErrorCode code = ErrorCode::kInvalidArgument;
  std::string field;    // what was being read or checked ("frame.length", "dem.png")
  std::string message;  // why, for a human

  // "field: message" (or just message when there is no field).
  std::string describe() const;
};

Error make_error(ErrorCode code, std::string field, std::string message);

template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Result(Error error) : state_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const { return state_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & {
    assert(ok());
    return std::get<0>(state_);
  }
  const T& value() const& {
    assert(ok());
    return std::get<0>(state_);
  }
  T&& value() && {
    assert(ok());
    return std::get<0>(std::move(state_));
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const Error& error() const {
    assert(!ok());
    return std::get<1>(state_);
  }

 private:
  std::variant<T, Error> state_;
};

// Result<void>: success or an Error.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT(google-explicit-constructor)

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const {
    assert(!ok_);
    return error_;
  }

 private:
  Error error_;
  bool ok_ = true;
};

}  // namespace loam

// Propagates an error from an expression returning Result or Status.
#define LOAM_TRY(expr)                                           \
  do {                                                           \
    auto&& loam_try_result_ = (expr);                            \
    if (!loam_try_result_.ok()) return loam_try_result_.error(); \
  } while (false)
