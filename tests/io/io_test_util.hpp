#pragma once
// Helpers shared by the io tests: a scratch directory per test and an "expect InputError whose
// message contains ..." assertion.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <initializer_list>
#include <string>

#include "core/error.hpp"

namespace ebh::test {

/// A fresh directory under the system temp dir, removed with its contents at the end.
struct ScratchDir {
  std::filesystem::path dir;
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = std::filesystem::temp_directory_path() /
          (std::string("ebh_io_") + info->test_suite_name() + "_" + info->name() + "_" + std::to_string(getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  ~ScratchDir() { std::filesystem::remove_all(dir); }
  std::string operator/(const std::string& name) const { return (dir / name).string(); }
  /// Number of entries in the directory (temporary files left behind show up here).
  std::size_t entries() const {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++n;
    return n;
  }
};

}  // namespace ebh::test

/// Runs `stmt`, expects an ebh::InputError whose message contains every one of the strings.
#define EXPECT_INPUT_ERROR(stmt, ...)                                                             \
  do {                                                                                            \
    try {                                                                                         \
      stmt;                                                                                       \
      ADD_FAILURE() << "no InputError from " #stmt;                                               \
    } catch (const ebh::InputError& e) {                                                          \
      const std::string msg = e.what();                                                           \
      for (const std::string& part : std::initializer_list<std::string>{__VA_ARGS__})                                             \
        EXPECT_NE(msg.find(part), std::string::npos) << "message '" << msg << "' lacks '" << part << "'"; \
      EXPECT_EQ(msg.find('\n'), std::string::npos) << "message is not one line: " << msg;         \
    }                                                                                             \
  } while (0)
