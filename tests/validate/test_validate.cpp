// The validation registry, the `column` and `hertz` cases (the convergence case runs a 44k-tet scene: it is
// exercised by `ebh validate convergence`, not by the unit tests).
#include <gtest/gtest.h>

#include "validate/validation.hpp"

namespace ebh {
namespace {

TEST(Validation, RegistryListsEachNameOnce) {
  std::vector<std::string> names;
  for (const Validation& v : validations()) {
    EXPECT_FALSE(v.description.empty()) << v.name;
    for (const auto& n : names) EXPECT_NE(n, v.name);
    names.push_back(v.name);
    EXPECT_EQ(find_validation(v.name), &v);
  }
  EXPECT_NE(find_validation("column"), nullptr);
  EXPECT_NE(find_validation("convergence"), nullptr);
  EXPECT_EQ(find_validation("no such validation"), nullptr);
}

TEST(Validation, ColumnMatchesTheAnalyticReaction) {
  const ValidationResult r = find_validation("column")->run({});
  EXPECT_TRUE(r.passed) << r.to_json().dump();
  // Linear tets reproduce the nu = 0 uniaxial solution exactly (column.cpp); what is left is the
  // local-global loop's stopping point after 30 exact iterations at 1 % strain.
  EXPECT_LT(r.error, 1e-6) << r.to_json().dump();
}

TEST(Validation, HertzIndentationForceFollowsTheTheory) {
  const ValidationResult r = find_validation("hertz")->run({});
  EXPECT_TRUE(r.passed) << r.to_json().dump();
  // The 15% budget is derived in hertz.cpp (finite block, tet size, penalty, small-strain theory).
  EXPECT_LE(r.error, 0.15);
}

}  // namespace
}  // namespace ebh
