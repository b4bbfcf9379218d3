// Two kinds of failure (house style rule 6):
//  - UserError: the user's input is wrong (bad path, broken image, unknown key,
//    too few photos). The message names the file and says what to do. Stage
//    executables turn it into exit code 2 and a one-line reason.
//  - InternalError: a broken invariant (a bug). Thrown by RELIGHT_CHECK.
// Modules never call exit(); they throw.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace relight {

// An error caused by the user's input or environment; `what()` says what to do.
class UserError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A violated internal invariant.
class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace internal {
// Collects a streamed message and throws on destruction (used by RELIGHT_CHECK).
class CheckFailure {
 public:
  CheckFailure(const char* file, int line, const char* condition) {
    stream_ << file << ":" << line << ": check failed: " << condition << " ";
  }
  [[noreturn]] ~CheckFailure() noexcept(false) { throw InternalError(stream_.str()); }
  std::ostream& stream() { return stream_; }

 private:
  std::ostringstream stream_;
};

// Collects a streamed message and throws a UserError on destruction.
class UserFailure {
 public:
  UserFailure() = default;
  [[noreturn]] ~UserFailure() noexcept(false) { throw UserError(stream_.str()); }
  std::ostream& stream() { return stream_; }

 private:
  std::ostringstream stream_;
};
}  // namespace internal

}  // namespace relight

// RELIGHT_CHECK(x > 0) << "x=" << x;  throws InternalError when false.
#define RELIGHT_CHECK(condition) \
  if (condition) {               \
  } else                         \
    ::relight::internal::CheckFailure(__FILE__, __LINE__, #condition).stream()

#define RELIGHT_CHECK_EQ(a, b) RELIGHT_CHECK((a) == (b)) << #a "=" << (a) << " " #b "=" << (b) << " "
#define RELIGHT_CHECK_LT(a, b) RELIGHT_CHECK((a) < (b)) << #a "=" << (a) << " " #b "=" << (b) << " "
#define RELIGHT_CHECK_LE(a, b) RELIGHT_CHECK((a) <= (b)) << #a "=" << (a) << " " #b "=" << (b) << " "
#define RELIGHT_CHECK_GT(a, b) RELIGHT_CHECK((a) > (b)) << #a "=" << (a) << " " #b "=" << (b) << " "
#define RELIGHT_CHECK_GE(a, b) RELIGHT_CHECK((a) >= (b)) << #a "=" << (a) << " " #b "=" << (b) << " "

// RELIGHT_USER_ERROR() << "photo " << path << " is not an image: remove it";  always throws UserError.
#define RELIGHT_USER_ERROR() ::relight::internal::UserFailure().stream()
