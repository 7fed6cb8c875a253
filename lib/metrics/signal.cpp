#include "metrics/signal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace ebh {

void fft_radix2(std::vector<std::complex<double>>& x) {
  const std::size_t n = x.size();
  // Bit-reversal permutation.
  for (std::size_t i = 1, j = 0; i < n; ++i) {
    std::size_t bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(x[i], x[j]);
  }
  // Butterflies; twiddles from std::polar per stage keep the error at O(eps log n).
  for (std::size_t len = 2; len <= n; len <<= 1) {
    const double ang = -2.0 * std::numbers::pi / static_cast<double>(len);
    for (std::size_t k = 0; k < len / 2; ++k) {
      const std::complex<double> w = std::polar(1.0, ang * static_cast<double>(k));
      for (std::size_t i = 0; i < n; i += len) {
        std::complex<double> u = x[i + k], v = x[i + k + len / 2] * w;
        x[i + k] = u + v;
        x[i + k + len / 2] = u - v;
      }
    }
  }
}

std::size_t floor_pow2(std::size_t n) {
  if (n == 0) return 0;
  std::size_t p = 1;
  while (p <= n / 2) p <<= 1;
  return p;
}

PowerSpectrum power_spectrum(const std::vector<std::vector<double>>& channels, double fs, std::size_t max_window,
                             std::size_t min_window) {
  PowerSpectrum s;
  if (channels.empty()) return s;
  const std::size_t len = channels.front().size();
  const std::size_t w = std::min(floor_pow2(max_window), floor_pow2(len));
  if (w < min_window || w < 2) return s;
  s.window = w;
  s.freq.resize(w / 2 + 1);
  s.power.assign(w / 2 + 1, 0.0);
  for (std::size_t k = 0; k <= w / 2; ++k) s.freq[k] = static_cast<double>(k) * fs / static_cast<double>(w);

  std::vector<std::size_t> starts;
  for (std::size_t b = 0; b + w <= len; b += w / 2) starts.push_back(b);
  if (starts.back() + w < len) starts.push_back(len - w);
  s.windows = starts.size();

  std::vector<double> hann(w);
  for (std::size_t i = 0; i < w; ++i)
    hann[i] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(w));

  std::vector<std::complex<double>> buf(w);
  for (const auto& ch : channels) {
    // The mean of the whole signal, not of each window: a window's own mean would drop the
    // power of content slower than the window (a slow press) from the total.
    double mean = 0;
    for (std::size_t i = 0; i < len; ++i) mean += ch[i];
    mean /= static_cast<double>(len);
    for (std::size_t b : starts) {
      for (std::size_t i = 0; i < w; ++i) buf[i] = (ch[b + i] - mean) * hann[i];
      fft_radix2(buf);
      for (std::size_t k = 0; k <= w / 2; ++k) {
        const double scale = (k == 0 || k == w / 2) ? 1.0 : 2.0;
        s.power[k] += scale * std::norm(buf[k]);
      }
    }
  }
  return s;
}

double power_fraction_above(const PowerSpectrum& s, double f_hz) {
  if (s.power.empty() || f_hz >= s.freq.back()) return std::numeric_limits<double>::quiet_NaN();
  double total = 0;
  for (const double p : s.power) total += p;
  if (!std::isfinite(total)) return std::numeric_limits<double>::quiet_NaN();
  return total > 0 ? power_above(s, f_hz) / total : 0.0;
}

double power_above(const PowerSpectrum& s, double f_hz) {
  double above = 0;
  for (std::size_t k = 0; k < s.power.size(); ++k)
    if (s.freq[k] > f_hz) above += s.power[k];
  return above;
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  for (double v : values)
    if (std::isnan(v)) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double pos = (static_cast<double>(values.size()) - 1.0) * std::clamp(p, 0.0, 100.0) / 100.0;
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  const double frac = pos - static_cast<double>(lo);
  if (frac == 0.0) return values[lo];
  return values[lo] + frac * (values[hi] - values[lo]);
}

}  // namespace ebh
