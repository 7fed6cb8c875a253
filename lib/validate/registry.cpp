// The table of validations (see validation.hpp for how to add one).
#include "validate/validation.hpp"

namespace ebh {

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
