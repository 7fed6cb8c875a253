#pragma once
// Errors in three tiers (STYLE.md): bad input is an InputError thrown at load with a message that
// names the file and the line, key or element; numerical trouble at run time is counted as a
// warning with a defined recovery; impossible states are assertions.
#include <stdexcept>
#include <string>

namespace ebh {

/// Bad user input (a file, an option). what() is one line: "FILE:LINE: what is wrong" or
/// "FILE: key 'a.b': what is wrong". Tools print it and exit non-zero.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A run that cannot go on because its numbers did (a non-finite or diverging state). what() is
/// one line naming where (tick, step) and the worst element; tools print it and exit with 4.
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace ebh
