// `ebh metrics OUT.h5 [--json] [--episodes] [--merge-gap-ms MS] [--fft-window TICKS]`:
// force-quality metrics of a replay output (docs/METRICS.md): a table, or JSON with --json.
// Exits 0 when the metrics were computed (a non-finite run included: see "finite"), 1 on bad input.
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "command.hpp"
#include "core/error.hpp"
#include "metrics/force_metrics.hpp"
#include "metrics/signal.hpp"
#include "options.hpp"

namespace {

// --fft-window's largest, ticks (17 minutes at 1 kHz); the option's check and its help give it.
constexpr std::int64_t kMaxFftWindow = std::int64_t{1} << 20;

struct MetricsArgs {
  std::string path;
  bool json = false, episodes = false;
  double merge_gap_ms = 5.0;
  std::size_t fft_window = 0;  // 0: by the output's haptic rate (ebh::fft_window_ticks)
};

void run(const MetricsArgs& a) {
  ebh::MetricsOptions opt;
  if (a.fft_window != 0 && ebh::floor_pow2(a.fft_window) != a.fft_window)
    throw ebh::InputError("--fft-window: " + std::to_string(a.fft_window) + " is not a power of two >= 2");
  const ebh::ReplayTrace trace = ebh::load_replay(a.path);
  // A shorter window's bins (H / W: 31 Hz for 32 ticks at 1 kHz) cannot place the 30 Hz
  // threshold, so its fraction is no measure of the force's high-frequency power.
  const std::size_t shortest = ebh::fft_min_window_ticks(opt, trace.haptic_hz);
  if (a.fft_window != 0 && a.fft_window < shortest)
    throw ebh::InputError("--fft-window: " + std::to_string(a.fft_window) + " ticks is below " + std::to_string(shortest) +
                          " (" + ebh::cli::format_number(ebh::kFftMinWindowS * 1e3) + " ms at the output's " +
                          ebh::cli::format_number(trace.haptic_hz) + " Hz), the shortest window whose bins place 30 Hz");
  opt.episode_merge_gap_s = a.merge_gap_ms * 1e-3;
  opt.fft_window = a.fft_window;
  const ebh::ForceMetrics m = ebh::compute_metrics(trace, opt);
  // The table says it under the episodes; JSON's "episodes_listed" only counts them.
  if (const std::string note = ebh::episodes_not_listed(m); a.episodes && a.json && !note.empty())
    std::fprintf(stderr, "ebh: warning: %s: %s\n", ebh::escape_unprintable(a.path).c_str(), note.c_str());
  if (a.json)
    std::printf("%s\n", ebh::to_json(m, a.episodes).dump().c_str());
  else
    std::fputs(ebh::format_table(m, a.episodes).c_str(), stdout);
}

void setup(CLI::App& root) {
  auto args = std::make_shared<MetricsArgs>();
  CLI::App* c = root.add_subcommand("metrics", "Force-quality metrics of a replay output (docs/METRICS.md)");
  c->add_option("replay", args->path, "replay output (HDF5)")->required();
  c->add_flag("--json", args->json, "print JSON instead of a table");
  c->add_flag("--episodes", args->episodes, "also give the metrics of each contact episode");
  c->add_option("--merge-gap-ms", args->merge_gap_ms, "contact episodes closer than this are merged (ms)")
      ->capture_default_str()
      ->check(ebh::cli::finite_number(0, ebh::cli::kNoUpperLimit));
  c->add_option("--fft-window", args->fft_window,
                "FFT window in haptic ticks (a power of two; default: 0.256 s of ticks, 256 at 1 kHz)")
      ->check(ebh::cli::whole_number(2, kMaxFftWindow));
  c->callback([args] { run(*args); });
}

}  // namespace

EBH_COMMAND(setup);
