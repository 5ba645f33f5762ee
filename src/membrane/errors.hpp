#pragma once
// The one error type of the membrane module beyond std::invalid_argument: a bad element,
// found either in a reference mesh (validation) or in a configuration during a force
// evaluation (a run that folded or collapsed an element). It carries the element index so a
// caller (the time loop) can report it or write the last good state before stopping.
#include <cstdint>
#include <stdexcept>
#include <string>

namespace capsflow::membrane {

class ElementError : public std::invalid_argument {
 public:
  ElementError(const std::string& message, std::int64_t element)
      : std::invalid_argument(message), element_(element) {}
  [[nodiscard]] std::int64_t element() const noexcept { return element_; }

 private:
  std::int64_t element_;
};

}  // namespace capsflow::membrane
