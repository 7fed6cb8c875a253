#pragma once
// A minimal JSON writer for the command line's --json outputs (scene info, validate, metrics).
// Values are built as a tree and printed with stable key order (insertion order).
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace ebh {

class Json {
 public:
  using Object = std::vector<std::pair<std::string, Json>>;
  using Array = std::vector<Json>;

  Json() : v_(nullptr) {}
  Json(std::nullptr_t) : v_(nullptr) {}
  Json(bool b) : v_(b) {}
  Json(int i) : v_(static_cast<double>(i)) {}
  Json(long i) : v_(static_cast<double>(i)) {}
  Json(long long i) : v_(static_cast<double>(i)) {}
  Json(unsigned long i) : v_(static_cast<double>(i)) {}
  Json(unsigned long long i) : v_(static_cast<double>(i)) {}
  Json(double d) : v_(d) {}
  Json(const char* s) : v_(std::string(s)) {}
  Json(std::string s) : v_(std::move(s)) {}
  Json(Array a) : v_(std::make_shared<Array>(std::move(a))) {}
  Json(Object o) : v_(std::make_shared<Object>(std::move(o))) {}

  static Json object() { return Json(Object{}); }
  static Json array() { return Json(Array{}); }
  template <class Range>
  static Json array_of(const Range& r) {
    Array a;
    for (const auto& x : r) a.emplace_back(x);
    return Json(std::move(a));
  }

  /// Adds (or replaces) a key of an object.
  Json& set(const std::string& key, Json value);
  /// Appends to an array.
  Json& push(Json value);

  /// The numbers (and booleans, as 0 and 1) of an object tree with their dotted keys, in order:
  /// {"a": 1, "b": {"c": 2, "d": "x"}} gives [("a", 1), ("b.c", 2)]. Text, null and arrays are
  /// left out. A table with one column per value (`ebh sweep`'s summary) uses it.
  std::vector<std::pair<std::string, double>> numbers() const;

  /// Serialises; indent < 0 prints on one line. Non-finite numbers print as null. The result is
  /// valid UTF-8 whatever the strings hold: a byte that is no part of valid UTF-8 is written as the
  /// text \xNN (JSON "\\xff"), as the text outputs show it (escape_unprintable).
  std::string dump(int indent = 2) const;

 private:
  void dump_to(std::string& out, int indent, int depth) const;
  void numbers_to(std::vector<std::pair<std::string, double>>& out, const std::string& prefix) const;
  std::variant<std::nullptr_t, bool, double, std::string, std::shared_ptr<Array>, std::shared_ptr<Object>> v_;
};

}  // namespace ebh
