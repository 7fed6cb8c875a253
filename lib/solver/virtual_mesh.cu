// The virtual mesh's haptic-rate iterations on a CUDA device, float32 (virtual_mesh_cuda.hpp).
//   begin_tick   [copy physical x in]  begin kernel (E_svc targets p_j, prediction)  copy q out
//   iteration    copy contacts in  scatter kernel  Jacobi kernel (gather over the edge CSR)  copy q out
//   end_tick     velocity kernel
// Each kernel writes its own slots; contacts are summed per vertex on the host in the given
// order (as on the CPU) and scattered to distinct vertices, so results are bitwise reproducible.
#include <cuda_runtime.h>

#include <cstdint>
#include <vector>

#include "energy/edge_spring.hpp"
#include "energy/quadratic.hpp"
#include "solver/cuda_util.cuh"
#include "solver/virtual_jacobi.hpp"
#include "solver/virtual_mesh_device.cuh"
#include "solver/virtual_mesh_cuda.hpp"

namespace ebh {
namespace {

constexpr int kBlock = 128;

struct VirtualDevice {
  int m = 0;
  float k_s = 0, k_svc = 0;
  Vec3f gravity;
  cuda::VirtualModelView model;
  const Vec3f* physical_x = nullptr;    // n
  Vec3f* v = nullptr;                   // m
  Vec3f* s = nullptr;                   // m
  Vec3f* q_start = nullptr;             // m
  Vec3f* p = nullptr;                   // m
  Vec3f* contact_kt = nullptr;          // m  sum k target (zero outside an iteration)
  float* contact_k = nullptr;           // m  sum k
};

/// One vertex's E_con sums for this iteration (a vertex appears once).
struct ContactSum {
  int vertex;
  float k;
  Vec3f kt;
};

__global__ void begin_kernel(VirtualDevice d, Vec3f* q, float h) {
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= d.m) return;
  d.p[j] = paired_point(d.physical_x, d.model.pair_vertex + 4 * j, d.model.pair_weight + 4 * j, d.model.pair_count[j]);  // Alg. 2 l. 1
  const Vec3f qj = q[j];
  const Vec3f sj = d.model.pinned[j] ? qj : predict_position(qj, d.v[j], d.gravity, h);                      // Alg. 2 l. 6
  d.q_start[j] = qj;
  d.s[j] = sj;
  q[j] = d.model.pinned[j] ? qj : iteration_start(qj, d.v[j], h);  // the iterations' start
}

__global__ void scatter_kernel(VirtualDevice d, const ContactSum* c, int count) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  d.contact_kt[c[i].vertex] = c[i].kt;
  d.contact_k[c[i].vertex] = c[i].k;
}

/// One Jacobi step per vertex (virtual_jacobi.hpp), as virtual_iteration.
__global__ void jacobi_kernel(VirtualDevice d, const Vec3f* q, Vec3f* q_next, float inv_h2) {
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= d.m) return;
  const Vec3f kt = d.contact_kt[j];
  const float ck = d.contact_k[j];
  d.contact_kt[j] = Vec3f{};  // this thread is the slot's only reader: clear for the next iteration
  d.contact_k[j] = 0.f;
  const Vec3f qj = q[j];
  if (d.model.pinned[j]) { q_next[j] = qj; return; }
  const float mh = d.model.mass[j] * inv_h2;
  Vec3f r = add_contact_residual(inertia_coupling_residual(mh, d.s[j], qj, d.p[j], d.k_svc), kt, ck, qj);
  for (int k = d.model.edge_offsets[j]; k < d.model.edge_offsets[j + 1]; ++k) {
    const int4 it = d.model.edge_items[k];
    add_edge_residual(r, edge_spring_gradient(q[it.x], q[it.y], d.model.rest_edge[it.z], d.k_s), it.w != 0);
  }
  q_next[j] = jacobi_update(qj, r, mh + d.model.stiff_diag[j] + ck);
}

__global__ void end_kernel(VirtualDevice d, const Vec3f* q, float v_scale) {
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= d.m) return;
  d.v[j] = v_scale * (q[j] - d.q_start[j]);  // Alg. 2 line 23, damped (tick_velocity_scale)
}

Vec3f to_float(const Vec3d& v) { return static_cast<Vec3f>(v); }

}  // namespace

struct CudaVirtualSolver::Impl {
  int m = 0, n = 0;
  double h = 0;
  double damping = 0;  // 1/s, VirtualModel::damping
  std::int64_t physical_version = 0;
  bool have_physical = false;
  cuda::Stream stream;
  cuda::VirtualModelArrays model;
  cuda::DeviceArray<float> contact_k;
  cuda::DeviceArray<Vec3f> physical_x, v, s, q_start, p, contact_kt, q[2];
  cuda::DeviceArray<ContactSum> contacts;
  cuda::PinnedArray<Vec3f> q_host, x_host;
  cuda::PinnedArray<ContactSum> contacts_host;
  std::vector<double> sum_k;      // m, host scratch of the contact sums (zero between iterations)
  std::vector<Vec3d> sum_kt;      // m
  std::vector<int> touched;       // vertices with a contact this iteration, first-seen order
  std::vector<std::uint8_t> is_touched;  // m
  int cur = 0;                    // q[cur] is the current q
  VirtualDevice dev;

  void download_q(std::span<Vec3d> q_out) {
    if (q_out.size() != size_t(m)) throw std::invalid_argument("CudaVirtualSolver: q_out has the wrong size");
    cudaStream_t st = stream.get();
    EBH_CUDA_CHECK(cudaMemcpyAsync(q_host.get(), q[cur].get(), m * sizeof(Vec3f), cudaMemcpyDeviceToHost, st));
    EBH_CUDA_CHECK(cudaStreamSynchronize(st));
    for (int j = 0; j < m; ++j) q_out[j] = static_cast<Vec3d>(q_host[j]);
  }
};

CudaVirtualSolver::CudaVirtualSolver(const VirtualModel& M) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  I.m = M.num_vertices;
  const int m = I.m;
  cudaStream_t st = I.stream.get();
  I.model.upload(M, st);
  for (auto* a : {&I.v, &I.s, &I.q_start, &I.p, &I.contact_kt, &I.q[0], &I.q[1]}) a->allocate(m);
  I.contact_k.allocate(m);
  I.contacts.allocate(m);
  I.q_host.allocate(m);
  I.contacts_host.allocate(m);
  EBH_CUDA_CHECK(cudaMemsetAsync(I.contact_kt.get(), 0, m * sizeof(Vec3f), st));
  EBH_CUDA_CHECK(cudaMemsetAsync(I.contact_k.get(), 0, m * sizeof(float), st));
  I.sum_k.assign(m, 0.0);
  I.sum_kt.assign(m, Vec3d{});
  I.touched.reserve(m);
  I.is_touched.assign(m, 0);

  VirtualDevice& d = I.dev;
  d.m = m;
  d.k_s = float(M.k_s);
  d.k_svc = float(M.k_svc);
  I.damping = M.damping;
  d.gravity = to_float(M.gravity);
  d.model = I.model.view();
  d.v = I.v.get();
  d.s = I.s.get();
  d.q_start = I.q_start.get();
  d.p = I.p.get();
  d.contact_kt = I.contact_kt.get();
  d.contact_k = I.contact_k.get();
  upload_state(make_virtual_state(M));
}

CudaVirtualSolver::~CudaVirtualSolver() = default;

void CudaVirtualSolver::upload_state(const VirtualState& state) {
  Impl& I = *impl_;
  if (state.q.size() != size_t(I.m) || state.v.size() != size_t(I.m))
    throw std::invalid_argument("CudaVirtualSolver::upload_state: state sizes do not match the model");
  std::vector<Vec3f> q(I.m), v(I.m);
  for (int j = 0; j < I.m; ++j) { q[j] = to_float(state.q[j]); v[j] = to_float(state.v[j]); }
  I.q[I.cur].upload(q.data(), I.stream.get());
  I.v.upload(v.data(), I.stream.get());
}

void CudaVirtualSolver::download_state(VirtualState& state) const {
  const Impl& I = *impl_;
  std::vector<Vec3f> q(I.m), v(I.m);
  I.q[I.cur].download(q.data(), I.stream.get());
  I.v.download(v.data(), I.stream.get());
  state.q.resize(I.m);
  state.v.resize(I.m);
  for (int j = 0; j < I.m; ++j) { state.q[j] = static_cast<Vec3d>(q[j]); state.v[j] = static_cast<Vec3d>(v[j]); }
}

void CudaVirtualSolver::begin_tick(std::span<const Vec3d> physical_x, std::int64_t physical_version, double h,
                                   std::span<Vec3d> q_out) {
  Impl& I = *impl_;
  cudaStream_t st = I.stream.get();
  I.h = h;
  if (!I.have_physical || physical_version != I.physical_version || physical_x.size() != size_t(I.n)) {
    if (physical_x.size() != size_t(I.n)) {
      I.n = static_cast<int>(physical_x.size());
      I.physical_x.allocate(I.n);
      I.x_host.allocate(I.n);
      I.dev.physical_x = I.physical_x.get();
    }
    for (int a = 0; a < I.n; ++a) I.x_host[a] = to_float(physical_x[a]);
    if (I.n > 0)
      EBH_CUDA_CHECK(cudaMemcpyAsync(I.physical_x.get(), I.x_host.get(), I.n * sizeof(Vec3f), cudaMemcpyHostToDevice, st));
    I.physical_version = physical_version;
    I.have_physical = true;
  }
  if (I.m == 0) return;
  begin_kernel<<<cuda::blocks_for(I.m, kBlock), kBlock, 0, st>>>(I.dev, I.q[I.cur].get(), float(h));
  EBH_CUDA_LAUNCH_CHECK(st, "begin_kernel");
  I.download_q(q_out);
}

void CudaVirtualSolver::iteration(std::span<const ContactTarget> contacts, std::span<Vec3d> q_out) {
  Impl& I = *impl_;
  cudaStream_t st = I.stream.get();
  // E_con sums per vertex in the given order, in double as on the CPU.
  for (const ContactTarget& c : contacts) {
    if (c.vertex < 0 || c.vertex >= I.m) throw std::invalid_argument("CudaVirtualSolver: contact vertex out of range");
    if (!I.is_touched[c.vertex]) { I.is_touched[c.vertex] = 1; I.touched.push_back(c.vertex); }
    I.sum_kt[c.vertex] += c.stiffness * c.target;
    I.sum_k[c.vertex] += c.stiffness;
  }
  const int count = static_cast<int>(I.touched.size());
  for (int i = 0; i < count; ++i) {
    const int j = I.touched[i];
    I.contacts_host[i] = ContactSum{j, float(I.sum_k[j]), to_float(I.sum_kt[j])};
    I.sum_k[j] = 0.0;
    I.sum_kt[j] = Vec3d{};
    I.is_touched[j] = 0;
  }
  I.touched.clear();
  if (count > 0) {
    EBH_CUDA_CHECK(cudaMemcpyAsync(I.contacts.get(), I.contacts_host.get(), count * sizeof(ContactSum),
                                   cudaMemcpyHostToDevice, st));
    scatter_kernel<<<cuda::blocks_for(count, kBlock), kBlock, 0, st>>>(I.dev, I.contacts.get(), count);
    EBH_CUDA_LAUNCH_CHECK(st, "scatter_kernel");
  }
  if (I.m == 0) return;
  const float inv_h2 = float(1.0 / (I.h * I.h));
  jacobi_kernel<<<cuda::blocks_for(I.m, kBlock), kBlock, 0, st>>>(I.dev, I.q[I.cur].get(), I.q[1 - I.cur].get(), inv_h2);
  EBH_CUDA_LAUNCH_CHECK(st, "jacobi_kernel");
  I.cur = 1 - I.cur;
  I.download_q(q_out);
}

void CudaVirtualSolver::end_tick() {
  Impl& I = *impl_;
  if (I.m == 0) return;
  cudaStream_t st = I.stream.get();
  end_kernel<<<cuda::blocks_for(I.m, kBlock), kBlock, 0, st>>>(I.dev, I.q[I.cur].get(), float(tick_velocity_scale(I.h, I.damping)));
  EBH_CUDA_LAUNCH_CHECK(st, "end_kernel");
}

}  // namespace ebh
