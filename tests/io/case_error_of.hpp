#pragma once
// The message of the CaseError that parsing a case text (named case.toml) throws: one line
// naming the file; fails the test when the text is accepted.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <span>
#include <string>

#include "io/case_config.hpp"

namespace capsflow::io::testing {

inline std::string error_of(const std::string& text, std::span<const std::string> overrides = {}) {
  try {
    (void)parse_case_text(text, "case.toml", overrides);
  } catch (const CaseError& e) {
    EXPECT_THAT(std::string(e.what()), ::testing::Not(::testing::HasSubstr("\n"))) << "one line";
    EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("case.toml: ")) << "names the file";
    return e.what();
  }
  ADD_FAILURE() << "no CaseError for:\n" << text;
  return {};
}

}  // namespace capsflow::io::testing
