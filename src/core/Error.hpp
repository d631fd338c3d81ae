#pragma once
#include <stdexcept>
#include <string>

namespace kf {

/// Every failure the user can cause or see (bad scene, I/O, device errors) is a kf::Error whose
/// message is one complete line: what went wrong, where, and what was expected.
class Error : public std::runtime_error {
public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// A scene file that fails validation; the message names file, line, key and expectation.
class SceneError : public Error {
public:
  using Error::Error;
};

/// The simulation became unstable (NaN, blow-up, dt collapse).
class InstabilityError : public Error {
public:
  using Error::Error;
};

} // namespace kf
