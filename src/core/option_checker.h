// OptionChecker: what the options structs' validate() share. Each check that
// fails records "<scope>.<name>: must be ... (got <value>)"; the first one
// is the error (empty when every check passed).
//
// Usage:
//   OptionChecker c("region_tracking");
//   c.inRange("irls_iterations", irls_iterations, 1, 50);           // [lo, hi]
//   c.atLeast("min_features", min_features, 1);                      // [lo, inf)
//   c.check(error_floor > 0 && error_floor <= 10, "error_floor", "must be in (0, 10]", error_floor);
//   return c.error();
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace imt {

// The options, when they are usable; else throws std::invalid_argument with
// validate()'s message. Every module checks its options this way, once, at
// construction: an invalid option is never replaced by a default. (The
// loaders, io/config.h and ros/params.h, validate before anything is built,
// so a user meets the message there, naming the parameter.)
template <class Options>
const Options& validated(const Options& options) {
  if (std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  return options;
}

class OptionChecker {
 public:
  // `scope`: the YAML section ("" for top-level parameters).
  explicit OptionChecker(std::string scope) : scope_(std::move(scope)) {}

  template <class T>
  void atLeast(const char* name, T value, T lo) {
    std::ostringstream os;
    os << "must be >= " << lo;
    check(value >= lo, name, os.str(), value);
  }
  template <class T>
  void inRange(const char* name, T value, T lo, T hi) {
    std::ostringstream os;
    os << "must be in [" << lo << ", " << hi << "]";
    check(value >= lo && value <= hi, name, os.str(), value);
  }
  // Any other condition (open bounds, bounds on other fields, choices).
  template <class T>
  void check(bool ok, const char* name, const std::string& what, const T& value) {
    if (ok || !error_.empty()) return;
    std::ostringstream os;
    os << (scope_.empty() ? "" : scope_ + ".") << name << ": " << what << " (got " << value << ")";
    error_ = os.str();
  }
  const std::string& error() const { return error_; }

 private:
  std::string scope_;
  std::string error_;
};

}  // namespace imt
