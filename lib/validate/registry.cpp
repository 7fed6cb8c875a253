// The table of validations (see validation.hpp for how to add one).
#include "validate/validation.hpp"

#include <algorithm>

#include "scene/scene.hpp"

namespace ebh {

std::vector<std::string> overrides_of_keys(const std::vector<std::string>& overrides, const std::vector<std::string>& keys) {
  // A key set whole or in part: `stiffness.k_s=5`, `stiffness={k_s: 5}` and `solver.method=direct` alike.
  const auto related = [](const std::string& a, const std::string& b) {
    const auto under = [](const std::string& x, const std::string& y) {
      return x.size() > y.size() && x.compare(0, y.size(), y) == 0 && x[y.size()] == '.';
    };
    return a == b || under(a, b) || under(b, a);
  };
  std::vector<std::string> out;
  for (const std::string& o : overrides) {
    const std::vector<std::string> set = override_keys(o);
    if (std::any_of(set.begin(), set.end(), [&](const std::string& k) {
          return std::any_of(keys.begin(), keys.end(), [&](const std::string& key) { return related(k, key); });
        }))
      out.push_back(o);
  }
  return out;
}

std::vector<std::string> with_matrix_values(const std::vector<std::string>& overrides,
                                            const std::vector<std::string>& matrix) {
  std::vector<std::string> keys;
  for (const std::string& m : matrix) keys.push_back(m.substr(0, m.find('=')));
  const std::vector<std::string> replaced = overrides_of_keys(overrides, keys);
  std::vector<std::string> out;
  for (const std::string& o : overrides)
    if (std::find(replaced.begin(), replaced.end(), o) == replaced.end()) out.push_back(o);
  out.insert(out.end(), matrix.begin(), matrix.end());
  return out;
}

const std::vector<Validation>& validations() {
  static const std::vector<Validation> table = {
      column_validation(),
      contact_validation(),
      coupling_validation(),
      convergence_validation(),
      hertz_validation(),
      stability_validation(),
  };
  return table;
}

const Validation* find_validation(const std::string& name) {
  for (const Validation& v : validations())
    if (v.name == name) return &v;
  return nullptr;
}

Json ValidationResult::to_json() const {
  Json j = Json::object();
  j.set("name", name);
  j.set("error", error);
  j.set("tolerance", tolerance);
  j.set("passed", passed);
  if (!summary.empty()) j.set("summary", summary);
  j.set("data", data);
  return j;
}

}  // namespace ebh
