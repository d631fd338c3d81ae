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

/// Input the user gave that cannot be used (a command-line value, a path): the command ends with
/// exit code 2, as for a bad scene, before it has written anything.
class InputError : public Error {
public:
  using Error::Error;
};

/// A scene file that fails validation; the message names file, line, key and expectation.
class SceneError : public InputError {
public:
  using InputError::InputError;
};

/// The simulation became unstable (NaN, blow-up, dt collapse).
class InstabilityError : public Error {
public:
  using Error::Error;
};

} // namespace kf
