#pragma once
// Error checking for the CUDA backend (STYLE.md, NVIDIA Warp notes): every runtime call is checked
// and reported with its file and line; after each kernel launch the launch error is checked, and
// debug builds (no NDEBUG) also synchronise so that an execution error names its launch.
// Included by .cu files only: it names CUDA types.
#include <cuda_runtime.h>

#include <cstddef>
#include <stdexcept>
#include <string>

namespace ebh::cuda {

[[noreturn]] inline void fail(cudaError_t e, const char* what, const char* file, int line) {
  throw std::runtime_error(std::string(file) + ":" + std::to_string(line) + ": " + what + ": " +
                           cudaGetErrorName(e) + " (" + cudaGetErrorString(e) + ")");
}

inline void check(cudaError_t e, const char* what, const char* file, int line) {
  if (e != cudaSuccess) fail(e, what, file, line);
}

/// After a kernel launch on `stream`: the launch error; in debug builds also the execution error
/// (unless the stream is being captured into a graph, where nothing executes yet).
inline void check_launch(cudaStream_t stream, const char* what, const char* file, int line) {
  check(cudaGetLastError(), what, file, line);
#ifndef NDEBUG
  cudaStreamCaptureStatus status = cudaStreamCaptureStatusNone;
  check(cudaStreamIsCapturing(stream, &status), what, file, line);
  if (status == cudaStreamCaptureStatusNone) check(cudaStreamSynchronize(stream), what, file, line);
#endif
}

}  // namespace ebh::cuda

#define EBH_CUDA_CHECK(call) ::ebh::cuda::check((call), #call, __FILE__, __LINE__)
#define EBH_CUDA_LAUNCH_CHECK(stream, name) ::ebh::cuda::check_launch((stream), name, __FILE__, __LINE__)

namespace ebh::cuda {

/// Device memory of n elements of T (cudaMalloc; no managed memory), freed on destruction.
template <class T>
class DeviceArray {
 public:
  DeviceArray() = default;
  explicit DeviceArray(std::size_t n) { allocate(n); }
  ~DeviceArray() { if (p_) cudaFree(p_); }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  void allocate(std::size_t n) {
    if (p_) { EBH_CUDA_CHECK(cudaFree(p_)); p_ = nullptr; }
    n_ = n;
    if (n > 0) EBH_CUDA_CHECK(cudaMalloc(reinterpret_cast<void**>(&p_), n * sizeof(T)));
  }
  /// Synchronous upload of a host array of size() elements.
  void upload(const T* host, cudaStream_t stream) {
    if (n_ == 0) return;
    EBH_CUDA_CHECK(cudaMemcpyAsync(p_, host, n_ * sizeof(T), cudaMemcpyHostToDevice, stream));
    EBH_CUDA_CHECK(cudaStreamSynchronize(stream));
  }
  /// Synchronous download into a host array of size() elements.
  void download(T* host, cudaStream_t stream) const {
    if (n_ == 0) return;
    EBH_CUDA_CHECK(cudaMemcpyAsync(host, p_, n_ * sizeof(T), cudaMemcpyDeviceToHost, stream));
    EBH_CUDA_CHECK(cudaStreamSynchronize(stream));
  }
  T* get() const { return p_; }
  std::size_t size() const { return n_; }

 private:
  T* p_ = nullptr;
  std::size_t n_ = 0;
};

/// Page-locked host memory (asynchronous copies, graph memcpy nodes), freed on destruction.
template <class T>
class PinnedArray {
 public:
  PinnedArray() = default;
  ~PinnedArray() { if (p_) cudaFreeHost(p_); }
  PinnedArray(const PinnedArray&) = delete;
  PinnedArray& operator=(const PinnedArray&) = delete;
  void allocate(std::size_t n) {
    if (p_) { EBH_CUDA_CHECK(cudaFreeHost(p_)); p_ = nullptr; }
    n_ = n;
    if (n > 0) EBH_CUDA_CHECK(cudaMallocHost(reinterpret_cast<void**>(&p_), n * sizeof(T)));
  }
  T* get() const { return p_; }
  T& operator[](std::size_t i) const { return p_[i]; }
  std::size_t size() const { return n_; }

 private:
  T* p_ = nullptr;
  std::size_t n_ = 0;
};

/// A stream of its own (non-blocking with respect to the legacy default stream).
class Stream {
 public:
  Stream() { EBH_CUDA_CHECK(cudaStreamCreateWithFlags(&s_, cudaStreamNonBlocking)); }
  ~Stream() { if (s_) cudaStreamDestroy(s_); }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return s_; }

 private:
  cudaStream_t s_ = nullptr;
};

inline int blocks_for(long long threads, int block) { return static_cast<int>((threads + block - 1) / block); }

/// Launches kernel(args...) on `stream`, with programmatic dependent launch when `programmatic`
/// (the kernel then waits for its predecessor with cudaGridDependencySynchronize); checked as
/// EBH_CUDA_LAUNCH_CHECK with `name`. Usable inside stream capture.
template <class... Params, class... Args>
void launch(bool programmatic, void (*kernel)(Params...), int grid, int block, std::size_t smem, cudaStream_t stream,
            const char* name, Args... args) {
  cudaLaunchConfig_t cfg{};
  cfg.gridDim = dim3(grid);
  cfg.blockDim = dim3(block);
  cfg.dynamicSmemBytes = smem;
  cfg.stream = stream;
  cudaLaunchAttribute attr[1];
  attr[0].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  attr[0].val.programmaticStreamSerializationAllowed = 1;
  cfg.attrs = programmatic ? attr : nullptr;
  cfg.numAttrs = programmatic ? 1 : 0;
  EBH_CUDA_CHECK(cudaLaunchKernelEx(&cfg, kernel, args...));
  EBH_CUDA_LAUNCH_CHECK(stream, name);
}

}  // namespace ebh::cuda
