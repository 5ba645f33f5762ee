#pragma once
// The two ways reading user input fails. Both carry one line (no '\n'): the file, the
// key or object, and the reason, ready to print as it is before exiting with status 2.
#include <stdexcept>

namespace capsflow::io {

// A case file (or a --set override) that cannot describe a run: syntax, unknown key,
// wrong type, impossible value, missing file.
class CaseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A checkpoint that cannot restart this run: unreadable, truncated, a missing dataset, or
// written for another domain or another set of fields.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace capsflow::io
