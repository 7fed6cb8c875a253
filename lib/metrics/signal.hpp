#pragma once
// Small signal-processing pieces for the force metrics: a radix-2 FFT, a windowed power
// spectrum and percentiles. No dependencies beyond the standard library.
#include <complex>
#include <cstddef>
#include <vector>

namespace ebh {

/// In-place iterative radix-2 Cooley-Tukey FFT, X_k = sum_n x_n e^{-2 pi i k n / W}.
/// x.size() must be a power of two (>= 1).
void fft_radix2(std::vector<std::complex<double>>& x);

/// Largest power of two <= n (0 for n == 0).
std::size_t floor_pow2(std::size_t n);

/// One-sided power spectrum of a multi-channel signal, averaged over windows (Welch's method).
/// channels: C signals of equal length L, sampled at rate fs (Hz). Windows of W samples
/// (W = min(max_window, floor_pow2(L))) start every W/2 samples; when the last one does not
/// reach the end of the signal, one more window ending at the last sample is added, so every
/// sample is covered. Each channel has its mean (over the whole signal) removed; each window is
/// multiplied by a Hann window. power[k] (k = 0..W/2) sums |X_k|^2 over channels and windows, bins 1..W/2-1
/// doubled for the negative frequencies; freq[k] = k fs / W. Empty when W < min_window.
struct PowerSpectrum {
  std::vector<double> freq;   // W/2+1, Hz
  std::vector<double> power;  // W/2+1, arbitrary units (only ratios are meaningful)
  std::size_t window = 0;     // W, samples
  std::size_t windows = 0;    // number of windows averaged
};
PowerSpectrum power_spectrum(const std::vector<std::vector<double>>& channels, double fs, std::size_t max_window,
                             std::size_t min_window);

/// Fraction of the spectrum's power (all bins: with the signal's mean removed, bin 0 holds
/// content slower than a window, still force fluctuation) in bins with freq > f_hz. 0 when the total is 0 (a constant signal has no
/// fluctuation at any frequency); NaN when the spectrum is empty or not finite, or when f_hz is at or
/// above its highest frequency (the Nyquist frequency: a 10 Hz trace says nothing about 30 Hz).
double power_fraction_above(const PowerSpectrum& s, double f_hz);

/// The spectrum's power in bins with freq > f_hz (its units: compare spectra of the same window).
double power_above(const PowerSpectrum& s, double f_hz);

/// Percentile p in [0, 100] with linear interpolation between order statistics at position
/// (n-1) p / 100 (numpy's default). NaN for empty input or when any value is NaN.
double percentile(std::vector<double> values, double p);

}  // namespace ebh
