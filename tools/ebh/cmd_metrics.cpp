// `ebh metrics OUT.h5 [--json] [--episodes] [--merge-gap-ms MS] [--fft-window TICKS]`:
// force-quality metrics of a replay output (docs/METRICS.md): a table, or JSON with --json.
// Exits 0 when the metrics were computed (a non-finite run included: see "finite"), 1 on bad input.
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "core/error.hpp"
#include "metrics/force_metrics.hpp"
#include "metrics/signal.hpp"
#include "options.hpp"

namespace {

constexpr std::size_t kMaxFftWindow = std::size_t{1} << 20;  // --fft-window, ticks

struct MetricsArgs {
  std::string path;
  bool json = false, episodes = false;
  double merge_gap_ms = 5.0;
  std::size_t fft_window = 256;
};

void run(const MetricsArgs& a) {
  ebh::MetricsOptions opt;
  if (a.fft_window < 2 || ebh::floor_pow2(a.fft_window) != a.fft_window)
    throw ebh::InputError("--fft-window: " + std::to_string(a.fft_window) + " is not a power of two >= 2");
  if (a.fft_window > kMaxFftWindow)
    throw ebh::InputError("--fft-window: " + std::to_string(a.fft_window) + " is over " + std::to_string(kMaxFftWindow) +
                          " ticks (17 minutes at 1 kHz)");
  opt.episode_merge_gap_s = a.merge_gap_ms * 1e-3;
  opt.fft_window = a.fft_window;
  if (opt.fft_min_window > opt.fft_window) opt.fft_min_window = opt.fft_window;
  const ebh::ForceMetrics m = ebh::compute_metrics(ebh::load_replay(a.path), opt);
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
  c->add_option("--fft-window", args->fft_window, "FFT window in haptic ticks (a power of two)")->capture_default_str();
  c->callback([args] { run(*args); });
}

}  // namespace

EBH_COMMAND(setup);
