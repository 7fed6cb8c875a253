#include "options.hpp"

#include <sched.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "scene/scene.hpp"

namespace ebh::cli {

std::string format_number(double v) { return shown_number(v); }

CLI::Validator finite_number(double lo, double hi, bool lo_open, const std::string& unit) {
  const std::string u = unit.empty() ? "" : " " + unit;
  const std::string range = std::isinf(hi) ? (lo_open ? "> " : ">= ") + format_number(lo) + u
                                           : std::string(lo_open ? "in (" : "in [") + format_number(lo) + ", " +
                                                 format_number(hi) + "]" + u;
  return CLI::Validator(
      [lo, hi, lo_open, range](std::string& text) -> std::string {
        const char* b = text.c_str();
        char* e = nullptr;
        errno = 0;
        const double v = std::strtod(b, &e);
        // ERANGE: an overflow (inf, refused below) or an underflow to a denormal or 0 (1e-320 is a
        // number); decimal only (strtod reads 0x10 as 16: --duration 0x10 ran the whole recording)
        const bool parsed = !text.empty() && e == b + text.size() && (errno != ERANGE || std::fabs(v) < 1) &&
                            text.find_first_of("xX") == std::string::npos;
        const bool in = parsed && std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi;
        return in ? std::string() : "expected a finite number " + range + ", got '" + escape_unprintable(text) + "'";
      },
      range);
}

unsigned usable_cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0) return static_cast<unsigned>(CPU_COUNT(&set));
  return std::thread::hardware_concurrency();
}

CLI::Validator whole_number(long long lo, long long hi) {
  const std::string range = "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        if (text.empty()) return "";  // refuse_empty_values' check says it
        long long v = 0;
        const char* b = text.data() + (!text.empty() && text[0] == '+' ? 1 : 0);
        const auto [end, ec] = std::from_chars(b, text.data() + text.size(), v);
        const bool in = ec == std::errc() && end == text.data() + text.size() && v >= lo && v <= hi;
        return in ? std::string() : "expected a whole number " + range + ", got '" + escape_unprintable(text) + "'";
      },
      range);
}

CLI::Validator seed_number() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
        errno = 0;
        if (digits) std::strtoull(text.c_str(), nullptr, 10);
        return digits && errno != ERANGE ? std::string()
                                         : "expected a whole number >= 0 (at most 2^64 - 1), got '" + escape_unprintable(text) + "'";
      },
      ">= 0");
}

void refuse_empty_values(CLI::App& app) {
  const CLI::Validator non_empty(
      [](std::string& text) { return text.empty() ? std::string("expected a value, got an empty one") : std::string(); }, "");
  for (CLI::Option* o : app.get_options())
    if (o->get_type_size_max() > 0) o->check(non_empty);
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) refuse_empty_values(*sub);
}

void check_set_once(const std::vector<std::string>& overrides) { check_overrides_once(overrides); }

void check_option_not_set(const std::vector<std::string>& overrides, const std::string& option, bool given,
                          const std::string& value, const std::string& key) {
  if (!given) return;
  for (const std::string& o : overrides)
    for (const std::string& k : override_keys(o))
      if (k == key || key.rfind(k + ".", 0) == 0)
        throw InputError(option + " " + value + ": and --set '" + o + "' give one value twice (the option would win)");
}

void check_known_names(const std::string& option, const std::string& what, const std::vector<std::string>& chosen,
                       const std::vector<std::string>& known) {
  for (const std::string& c : chosen) {
    if (std::find(known.begin(), known.end(), c) != known.end()) continue;
    std::string list;
    for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
    throw InputError(option + ": no " + what + " '" + c + "' (known: " + list + ")");
  }
}

}  // namespace ebh::cli
