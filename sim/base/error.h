#pragma once
// Error type used across Handson libraries. Library code never exits the process: it throws
// handson::Error with a message meant for the user, and the command line prints it and returns a
// non-zero status.
#include <stdexcept>
#include <string>

namespace handson {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace handson
