#include "io/json.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "core/error.hpp"

namespace ebh {

Json& Json::set(const std::string& key, Json value) {
  auto* o = std::get_if<std::shared_ptr<Object>>(&v_);
  if (!o) throw std::logic_error("Json::set on a non-object");
  for (auto& [k, v] : **o)
    if (k == key) { v = std::move(value); return *this; }
  (*o)->emplace_back(key, std::move(value));
  return *this;
}

Json& Json::push(Json value) {
  auto* a = std::get_if<std::shared_ptr<Array>>(&v_);
  if (!a) throw std::logic_error("Json::push on a non-array");
  (*a)->push_back(std::move(value));
  return *this;
}

std::vector<std::pair<std::string, double>> Json::numbers() const {
  std::vector<std::pair<std::string, double>> out;
  numbers_to(out, "");
  return out;
}

void Json::numbers_to(std::vector<std::pair<std::string, double>>& out, const std::string& prefix) const {
  if (const auto* d = std::get_if<double>(&v_)) out.emplace_back(prefix, *d);
  else if (const auto* b = std::get_if<bool>(&v_)) out.emplace_back(prefix, *b ? 1.0 : 0.0);
  else if (const auto* o = std::get_if<std::shared_ptr<Object>>(&v_))
    for (const auto& [k, v] : **o) v.numbers_to(out, prefix.empty() ? k : prefix + "." + k);
}

/// Writes `s` as a JSON string. JSON text is UTF-8 (RFC 8259, section 8.1): a byte of `s` that is
/// no part of valid UTF-8 (a Latin-1 file name, an attribute stored as raw bytes) is written as the
/// four characters \xNN, as escape_unprintable() shows it in the text outputs (so `ebh metrics`
/// and `ebh metrics --json` name the same file the same way). Not U+FFFD, which loses the byte, nor
/// \u00NN, which reads as another, valid name (U+00FF is the bytes c3 bf); a name holding a real
/// "\xff" reads the same, as in the text outputs.
static void escape(std::string& out, const std::string& s) {
  out += '"';
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c >= 0x80) {
      const std::size_t len = utf8_sequence_length(s, i);
      if (len == 0) {
        out += '\\';  // the backslash of escape_unprintable's \xNN, escaped for JSON
        out += escape_unprintable(s.substr(i, 1));
      } else {
        out.append(s, i, len);
        i += len - 1;
      }
      continue;
    }
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);  // ASCII
        }
    }
  }
  out += '"';
}

void Json::dump_to(std::string& out, int indent, int depth) const {
  auto newline = [&](int d) {
    if (indent < 0) return;
    out += '\n';
    out.append(static_cast<size_t>(indent * d), ' ');
  };
  if (std::holds_alternative<std::nullptr_t>(v_)) {
    out += "null";
  } else if (auto* b = std::get_if<bool>(&v_)) {
    out += *b ? "true" : "false";
  } else if (auto* d = std::get_if<double>(&v_)) {
    if (!std::isfinite(*d)) {
      out += "null";
    } else if (*d == std::floor(*d) && std::fabs(*d) < 1e15) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(*d));
      out += buf;
    } else {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.10g", *d);
      out += buf;
    }
  } else if (auto* s = std::get_if<std::string>(&v_)) {
    escape(out, *s);
  } else if (auto* a = std::get_if<std::shared_ptr<Array>>(&v_)) {
    out += '[';
    bool first = true;
    for (const auto& x : **a) {
      if (!first) out += indent < 0 ? ", " : ",";
      first = false;
      newline(depth + 1);
      x.dump_to(out, indent, depth + 1);
    }
    if (!(*a)->empty()) newline(depth);
    out += ']';
  } else if (auto* o = std::get_if<std::shared_ptr<Object>>(&v_)) {
    out += '{';
    bool first = true;
    for (const auto& [k, x] : **o) {
      if (!first) out += indent < 0 ? ", " : ",";
      first = false;
      newline(depth + 1);
      escape(out, k);
      out += ": ";
      x.dump_to(out, indent, depth + 1);
    }
    if (!(*o)->empty()) newline(depth);
    out += '}';
  }
}

std::string Json::dump(int indent) const {
  std::string out;
  dump_to(out, indent, 0);
  return out;
}

}  // namespace ebh
