#pragma once
// Result<T>: a value or an Error. Bad input (unreadable file, malformed line,
// impossible setting) is an Error; a defect of the print is a Finding (finding.hpp).
#include <optional>
#include <string>
#include <utility>
#include <variant>

namespace printtwin {

/// What kind of failure; the CLI maps it to an exit code (usage 2, bad input 3, internal 4).
enum class ErrorCode { usage = 2, bad_input = 3, internal = 4 };

/// A failure that stops a stage. `file` and `line` locate it when it comes from input text.
struct Error {
  ErrorCode code = ErrorCode::bad_input;
  std::string message;       ///< What went wrong and what was expected, one sentence.
  std::string file;          ///< Input file, empty if none.
  std::optional<long> line;  ///< 1-based line in `file`, if the input is text.

  /// "file:line: message" (parts omitted when unknown).
  [[nodiscard]] std::string describe() const {
    std::string out;
    if (!file.empty()) {
      out += file;
      if (line) out += ":" + std::to_string(*line);
      out += ": ";
    }
    out += message;
    return out;
  }
};

inline Error bad_input(std::string message, std::string file = {}, std::optional<long> line = {}) {
  return Error{ErrorCode::bad_input, std::move(message), std::move(file), line};
}
inline Error usage_error(std::string message) {
  return Error{ErrorCode::usage, std::move(message), {}, {}};
}
inline Error internal_error(std::string message) {
  return Error{ErrorCode::internal, std::move(message), {}, {}};
}

/// A value of type T or an Error. Check `ok()` (or `operator bool`) before `value()`.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : data_(std::move(value)) {}      // NOLINT: implicit by design
  Result(Error error) : data_(std::move(error)) {}  // NOLINT: implicit by design

  [[nodiscard]] bool ok() const { return data_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & { return std::get<0>(data_); }
  const T& value() const& { return std::get<0>(data_); }
  T&& value() && { return std::get<0>(std::move(data_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const Error& error() const { return std::get<1>(data_); }

 private:
  std::variant<T, Error> data_;
};

/// Success or an Error, for operations without a value.
struct Ok {};
using Status = Result<Ok>;

}  // namespace printtwin
