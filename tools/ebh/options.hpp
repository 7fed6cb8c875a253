#pragma once
// Checks shared by the commands' options, one definition each.
#include <CLI/CLI.hpp>

#include <limits>
#include <string>
#include <vector>

namespace ebh::cli {

/// v as "%g": the form option values take in messages.
std::string format_number(double v);

inline constexpr double kNoUpperLimit = std::numeric_limits<double>::infinity();

/// A CLI11 check for a numeric option: a finite number in [lo, hi] ((lo, hi] with lo_open; hi may be
/// kNoUpperLimit). CLI11 reads "nan" and "inf" as numbers; this refuses them, so
/// `--duration nan` is "ebh: error: --duration: expected a finite number > 0, got 'nan'" rather
/// than a silent full replay. `unit` is appended to the range in messages ("Hz").
CLI::Validator finite_number(double lo, double hi, bool lo_open = false, const std::string& unit = "");

/// The cores this process may run on: its CPU affinity (taskset, a job's cpuset), which OpenMP
/// takes its default thread count from; the machine's where that cannot be read.
unsigned usable_cores();

/// A CLI11 check for a count: a whole number in [lo, hi] in decimal digits. CLI11 says "Could not
/// convert: --every = 1.5" of a fraction and of a number its type cannot hold, reads 1e30 into an
/// unsigned option as 2^64 - 1, and words a PositiveNumber check's range with a 300-digit bound;
/// this says "--every: expected a whole number in [1, 2147483647], got '1.5'".
CLI::Validator whole_number(long long lo, long long hi);

/// A CLI11 check for a seed: a whole number 0 .. 2^64 - 1 in decimal digits. CLI11 reads "-1"
/// into an unsigned option as 2^64 - 1 (a different seed than the user meant, written into the
/// output's provenance as such); this refuses it: "--seed: expected a whole number >= 0, got '-1'".
CLI::Validator seed_number();

/// Refuses an empty value for every option of `app` and its subcommands that takes one (flags take
/// none): "--level: expected a value, got an empty one". An empty value otherwise reads as the
/// option's default (`--level ''` as 0, `--recording ''` as not given) and a script whose variable
/// is unset runs something it did not ask for. Called once the options are added.
void refuse_empty_values(CLI::App& app);

/// Throws InputError "OPTION: no NAME 'x' (known: a, b, c)" unless every chosen name is known:
/// a filter that matches nothing must not pass silently (`ebh gate --case nosuchcase`).
void check_known_names(const std::string& option, const std::string& what, const std::vector<std::string>& chosen,
                       const std::vector<std::string>& known);

/// Throws InputError "--set 'k=2': key 'k' given twice (also --set 'k=1')" when two overrides name
/// one key: the last would win silently (a sweep plan refuses a key twice as well).
void check_set_once(const std::vector<std::string>& overrides);

/// Throws InputError "--haptic-hz 2000: and --set 'time.haptic_hz=500' give one value twice" when
/// an option (`given`) and an override set the same scene key: the option would win silently.
void check_option_not_set(const std::vector<std::string>& overrides, const std::string& option, bool given,
                          const std::string& value, const std::string& key);

}  // namespace ebh::cli
