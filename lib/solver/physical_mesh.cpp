// The physical mesh under Projective Dynamics: model building and Algorithm 1.
#include "solver/physical_mesh.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <string>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "energy/arap.hpp"
#include "energy/volume.hpp"
#include "energy/polar_svd.hpp"
#include "energy/quadratic.hpp"
#include "energy/rotation.hpp"
#include "mesh/csr.hpp"
#include "mesh/lumped_masses.hpp"
#include "mesh/morton.hpp"
#include "mesh/quality.hpp"
#include "solver/local_kernels.hpp"
#include "solver/shared_loops.hpp"
#include "solver/physical_region.hpp"
#include "solver/spectrum.hpp"
#include "solver/virtual_mesh.hpp"

namespace ebh {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// ---- Algorithm 1, stage by stage --------------------------------------------------------------
// Each stage is a loop over independent elements (for_chunks): an OpenMP work-sharing loop called
// from inside physical_step's one parallel region (an orphaned `omp for`; static schedules give
// every thread the same share each iteration), or, with SharedLoops, chunks that the one physical
// thread and a waiting helper take in turn. Either way each element is computed by the same code
// from the same inputs: the same bits.

constexpr double kRotationTol = 1e-9;  ///< radians: the Mueller update stops below this angle
constexpr double kStandardGravity = 9.81;  ///< m/s^2, the residual's scale (PhysicalModel::weight_norm)
/// The bounded diagonal keeps lambda_max(D^-1 A) at or below this: with the relaxation 0.9,
/// gamma lambda_max <= 1.89 < 2 (the committed scenes' meshes have 1.88-2.04 with A(a, a)).
constexpr double kLambdaLimit = 2.1;
constexpr double kSpectrumMargin = 1.02; ///< on Lanczos' estimate of lambda_max (a lower bound)

/// Alg. 1 lines 1-2: s = x + h v + h^2 g (pinned: s = x), x <- x + h v (iteration_start: not s,
/// docs/MODEL.md "The iterations' start"), from the state copied into the local order. With an
/// awake region a sleeping vertex starts, and stays, where it is (x = x_start: v = 0 at the end).
void predict(const PhysicalModel& model, PhysicalWorkspace& ws, const PhysicalState& state, const PhysicalRegion* region,
             SharedLoops* shared) {
  const PhysicalLocalArrays& L = model.local;
  auto start = [&](int i, bool held) {
    const int a = model.vertex_order[i];
    const Vec3d x = state.x[a], v = state.v[a];
    ws.x_start[i] = x;
    ws.s[i] = L.pinned[i] ? x : predict_position(x, v, model.gravity, model.h);
    ws.x[i] = held ? x : iteration_start(x, v, model.h);
    ws.x_prev[i] = ws.x[i];
  };
  if (region) {
    const std::uint8_t* awake = region->awake.data();
    for_chunks(shared, model.num_vertices, kVertexChunk, [&](int begin, int end) {
      for (int i = begin; i < end; ++i) start(i, L.pinned[i] || !awake[i]);
    });
    return;
  }
  for_chunks(shared, model.num_vertices, kVertexChunk, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) start(i, L.pinned[i]);
  });
}

/// Alg. 1 lines 6-8 (ConstraintProjection): per tet R_t and its corner forces; per virtual vertex
/// the E_svc force k_svc (q_j - p_j) with p_j = sum w x. Ends with a barrier. With an awake region
/// (physical_step passes null for one that holds every vertex): its tet blocks and virtual vertices only.
void local_step(const PhysicalModel& model, PhysicalWorkspace& ws, PhysicalState& state,
                std::span<const Vec3d> virtual_q, const PhysicalStepParams& params, const PhysicalRegion* region,
                SharedLoops* shared) {
  const TetKernelData tets{model.num_tets, model.corner_soa.data(), model.shape_grad_soa.data(),
                           model.weight_soa.data(), model.det_ratio};
  auto pair_force = [&](int j) {
    const Vec3d p = paired_point(ws.x.data(), model.local.pair_vertex[j].data(), model.pair_weight[j].data(),
                                 model.pair_count[j]);
    ws.cpl_force[j] = coupling_gradient_virtual(p, virtual_q[j], model.k_svc);  // k_svc (q - p)
  };
  if (region) {
    const int* blocks = region->tet_blocks.data();
    auto tet_range = [&](int k0, int k1) {
      for (int k = k0; k < k1; ++k)
        local_step_tet_blocks(tets, ws.x.data(), state.rotation.data(), ws.tet_force.data(),
                              params.rotation_iterations, kRotationTol, blocks[k], blocks[k] + 1);
    };
    const int nb = static_cast<int>(region->tet_blocks.size());
    if (shared) {
      shared->run(nb, kTetBlockChunk, tet_range);
    } else {
#pragma omp for schedule(static) nowait
      for (int k = 0; k < nb; ++k) tet_range(k, k + 1);
    }
    const int* ids = region->virtuals.data();
    for_chunks(shared, static_cast<int>(region->virtuals.size()), 2 * kVertexChunk, [&](int begin, int end) {
      for (int k = begin; k < end; ++k) pair_force(ids[k]);
    });
    return;
  }
  if (shared)
    shared->run(tet_blocks(model.num_tets), kTetBlockChunk, [&](int b0, int b1) {
      local_step_tet_blocks(tets, ws.x.data(), state.rotation.data(), ws.tet_force.data(),
                            params.rotation_iterations, kRotationTol, b0, b1);
    });
  else
    local_step_tets(tets, ws.x.data(), state.rotation.data(), ws.tet_force.data(), params.rotation_iterations,
                    kRotationTol);  // omp for nowait
  for_chunks(shared, model.num_virtual, 2 * kVertexChunk, [&](int begin, int end) {
    for (int j = begin; j < end; ++j) pair_force(j);
  });
}

/// r_i = -grad E_soft at x_i with the local step's projections (i a local index), gathered in a
/// fixed order: inertia, the corner forces of the incident tets, the E_svc forces.
inline Vec3d vertex_residual(const PhysicalLocalArrays& L, const PhysicalWorkspace& ws, const Vec3d* x, int i,
                             double inv_h2) {
  Vec3d r = (L.mass[i] * inv_h2) * (ws.s[i] - x[i]);                                 // -dE_k/dx
  for (int k = L.tet_offsets[i]; k < L.tet_offsets[i + 1]; ++k)
    r += ws.tet_force[L.force_entries[k]];                                           // -dE_vol/dx
  for (int k = L.cpl_offsets[i]; k < L.cpl_offsets[i + 1]; ++k)
    r += L.cpl_weight[k] * ws.cpl_force[L.cpl_virtual[k]];                           // -dE_svc/dx
  return r;
}

/// Free vertex i's residual and its Jacobi-type update (residual_and_update's per-vertex body).
[[gnu::always_inline]] inline void update_vertex(const PhysicalLocalArrays& L, PhysicalWorkspace& ws,
                                                 Vec3d* __restrict x, int i, SolverSpec::Method method, double gamma,
                                                 double omega, double inv_h2) {
  const Vec3d r = vertex_residual(L, ws, x, i, inv_h2);
  ws.r[i] = r;
  if (method == SolverSpec::Method::Jacobi) {
    x[i] += (gamma / L.diag[i]) * r;
  } else if (method == SolverSpec::Method::Chebyshev) {
    const Vec3d xk = x[i];
    x[i] = omega * ((gamma / L.diag[i]) * r + xk - ws.x_prev[i]) + ws.x_prev[i];
    ws.x_prev[i] = xk;
  }
}

/// The residual r = -grad E_soft (0 on pinned vertices) fused with Alg. 1 line 9
/// (GlobalSynthesis) for the Jacobi-type methods, per vertex (each vertex reads and writes only
/// its own x, so the order does not change the bits); ends with a barrier.
///   jacobi:    x <- x + gamma D^-1 r
///   chebyshev: x_{k+1} = omega (gamma D^-1 r + x_k - x_{k-1}) + x_{k-1}   (Wang 2015, eq. 12)
///   direct:    r only (global_direct follows)
void residual_and_update(const PhysicalModel& model, PhysicalWorkspace& ws, SolverSpec::Method method, double gamma,
                         double omega, const PhysicalRegion* region, SharedLoops* shared) {
  const double inv_h2 = 1.0 / (model.h * model.h);
  const PhysicalLocalArrays& L = model.local;
  Vec3d* __restrict x = ws.x.data();
  if (region) {  // the awake vertices (free, the Jacobi-type methods only)
    const int* ids = region->vertices.data();
    for_chunks(shared, static_cast<int>(region->vertices.size()), kVertexChunk, [&](int begin, int end) {
      for (int k = begin; k < end; ++k) update_vertex(L, ws, x, ids[k], method, gamma, omega, inv_h2);
    });
    return;
  }
  for_chunks(shared, model.num_vertices, kVertexChunk, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      if (L.pinned[i]) { ws.r[i] = Vec3d{}; continue; }  // never moves: x = x_prev = s
      update_vertex(L, ws, x, i, method, gamma, omega, inv_h2);
    }
  });
}

/// ||r|| over the awake vertices, in their (ascending local) order.
double region_residual_norm(const PhysicalWorkspace& ws, const PhysicalRegion& region) {
  double sum = 0;
  for (const int i : region.vertices) sum += squared_norm(ws.r[i]);
  return std::sqrt(sum);
}

/// ||r|| over free vertices (pinned rows are 0), summed serially in the file's vertex order: the
/// same bits for any thread count and either order.
double residual_norm(const PhysicalModel& model, const PhysicalWorkspace& ws) {
  double sum = 0;
  for (const int i : model.vertex_local) sum += squared_norm(ws.r[i]);
  return std::sqrt(sum);
}

/// The exact global step: x_f <- x_f + A_ff^-1 r_f (serial: call from one thread).
void global_direct(const PhysicalModel& model, const PhysicalDirectSolver& direct, PhysicalWorkspace& ws) {
  const int nf = model.num_free;
  if (nf == 0) return;
  const std::vector<int>& rows = model.local.free_vertices;
  for (int k = 0; k < nf; ++k) {
    const Vec3d r = ws.r[rows[k]];
    ws.rhs(k, 0) = r.x; ws.rhs(k, 1) = r.y; ws.rhs(k, 2) = r.z;
  }
  ws.dx = direct.ldlt.solve(ws.rhs);
  for (int k = 0; k < nf; ++k) ws.x[rows[k]] += Vec3d{ws.dx(k, 0), ws.dx(k, 1), ws.dx(k, 2)};
}

/// Alg. 1 line 11: v = (1 - damping) (x - x_start) / h; x and v back into the state's order.
void update_velocities(const PhysicalModel& model, const PhysicalWorkspace& ws, PhysicalState& state,
                       SharedLoops* shared) {
  const double c = (1.0 - model.damping) / model.h;
  for_chunks(shared, model.num_vertices, kVertexChunk, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const int a = model.vertex_order[i];
      state.x[a] = ws.x[i];
      state.v[a] = c * (ws.x[i] - ws.x_start[i]);
    }
  });
}

/// D over the free rows (see PhysicalModel::diag); the pinned rows keep A(a, a), never used.
/// Bounded: the smallest theta in [0, 1/2] (bisection, 1/64) with lambda_max(D_theta^-1 A) <= 2.1,
/// D_theta = max(A(a, a), theta D_l1(a)), from Lanczos estimates with a 2% margin; theta = 1/2
/// satisfies it by construction (D >= D_l1 / 2 >= A / 2), theta = 0 is the paper's diagonal.
void choose_diagonal(PhysicalModel& M, const Eigen::SparseMatrix<double>& A, SolverSpec::Diagonal kind) {
  const int nf = M.num_free;
  std::vector<double> plain(nf), D(nf);
  for (int i = 0; i < nf; ++i) plain[i] = M.diag[M.free_vertices[i]];
  Eigen::MatrixXd basis;  // the Lanczos vectors, one allocation for every estimate below
  M.spectrum = estimate_spectrum(A, plain, 40, &basis);
  if (kind == SolverSpec::Diagonal::Bounded && M.spectrum.lambda_max * kSpectrumMargin > kLambdaLimit) {
    const std::vector<double> l1 = l1_row_sums(A);
    auto bounded = [&](double theta) {
      for (int i = 0; i < nf; ++i) D[i] = std::max(plain[i], theta * l1[i]);
      return estimate_spectrum(A, D, 40, &basis);
    };
    double lo = 0, hi = 0.5;  // lo fails, hi holds
    SpectrumEstimate at_hi = bounded(hi);
    for (int it = 0; it < 6; ++it) {
      const double mid = 0.5 * (lo + hi);
      const SpectrumEstimate e = bounded(mid);
      if (e.lambda_max * kSpectrumMargin <= kLambdaLimit) { hi = mid; at_hi = e; } else { lo = mid; }
    }
    for (int i = 0; i < nf; ++i) D[i] = std::max(plain[i], hi * l1[i]);
    M.diag_theta = hi;
    M.spectrum = at_hi;
    for (int i = 0; i < nf; ++i) {
      if (D[i] > plain[i]) ++M.diag_bounded_rows;
      M.diag[M.free_vertices[i]] = D[i];
    }
  }
}

/// PhysicalModel's local order (tet_slot, vertex_order, vertex_local) and the slot-ordered
/// copies of the tets' data; `morton` off: the file's order.
void set_local_order(PhysicalModel& M, bool morton) {
  const int n = M.num_vertices, T = M.num_tets;
  M.vertex_order.resize(n);
  std::iota(M.vertex_order.begin(), M.vertex_order.end(), 0);
  std::vector<int> slot_tet(T);
  std::iota(slot_tet.begin(), slot_tet.end(), 0);
  if (morton && T > 0) {
    const MortonBox box = morton_box(M.rest);
    M.vertex_order = morton_order(M.rest, box);
    std::vector<Vec3d> centroid(T);
    for (int t = 0; t < T; ++t)
      centroid[t] = 0.25 * (M.rest[M.tets[t][0]] + M.rest[M.tets[t][1]] + M.rest[M.tets[t][2]] + M.rest[M.tets[t][3]]);
    // The tets of the full SIMD blocks in Morton order; the last partial block's keep their slots
    // (a partial block's lanes may round differently from a full block's).
    const int full = T - T % kTetLanes;
    const std::vector<int> order = morton_order(std::span(centroid).first(full), box);
    std::copy(order.begin(), order.end(), slot_tet.begin());
  }
  M.vertex_local.resize(n);
  for (int i = 0; i < n; ++i) M.vertex_local[M.vertex_order[i]] = i;
  M.tet_slot.resize(T);
  for (int s = 0; s < T; ++s) M.tet_slot[slot_tet[s]] = s;
  M.corner_soa.resize(4 * size_t(T));
  M.shape_grad_soa.resize(9 * size_t(T));
  M.weight_soa.resize(T);
  for (int s = 0; s < T; ++s) {
    const int t = slot_tet[s];
    M.weight_soa[s] = M.tet_weight[t];
    for (int c = 0; c < 4; ++c) {
      M.corner_soa[size_t(c) * T + s] = M.vertex_local[M.tets[t][c]];
      if (c > 0)
        for (int i = 0; i < 3; ++i) M.shape_grad_soa[size_t(3 * c - 3 + i) * T + s] = M.shape_grad[4 * size_t(t) + c][i];
    }
  }
}

/// PhysicalModel::local from the file order's arrays and the local order (the model complete).
void set_local_arrays(PhysicalModel& M) {
  const int n = M.num_vertices;
  PhysicalLocalArrays& L = M.local;
  L.mass.resize(n);
  L.diag.resize(n);
  L.pinned.resize(n);
  L.tet_offsets.assign(1, 0);
  L.cpl_offsets.assign(1, 0);
  L.force_entries.clear();
  L.cpl_virtual.clear();
  L.cpl_weight.clear();
  for (int i = 0; i < n; ++i) {
    const int a = M.vertex_order[i];
    L.mass[i] = M.mass[a];
    L.diag[i] = M.diag[a];
    L.pinned[i] = M.pinned[a];
    for (int k = M.tet_offsets[a]; k < M.tet_offsets[a + 1]; ++k)
      L.force_entries.push_back(4 * M.tet_slot[M.tet_entries[k] >> 2] + (M.tet_entries[k] & 3));
    L.tet_offsets.push_back(static_cast<int>(L.force_entries.size()));
    for (int k = M.cpl_offsets[a]; k < M.cpl_offsets[a + 1]; ++k) {
      L.cpl_virtual.push_back(M.cpl_virtual[k]);
      L.cpl_weight.push_back(M.cpl_weight[k]);
    }
    L.cpl_offsets.push_back(static_cast<int>(L.cpl_virtual.size()));
  }
  L.pair_vertex = M.pair_vertex;
  for (int j = 0; j < M.num_virtual; ++j)
    for (int k = 0; k < M.pair_count[j]; ++k) L.pair_vertex[j][k] = M.vertex_local[M.pair_vertex[j][k]];
  L.free_vertices.resize(M.num_free);
  for (int r = 0; r < M.num_free; ++r) L.free_vertices[r] = M.vertex_local[M.free_vertices[r]];
}

}  // namespace

Eigen::SparseMatrix<double> assemble_global_matrix(const PhysicalModel& M) {
  const int n = M.num_vertices, T = M.num_tets, m = M.num_virtual;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(16 * size_t(T) + size_t(n) + 16 * size_t(m));
  const double factor = volume_matrix_factor(M.det_ratio);  // E_det's share of a tet's weight
  for (int a = 0; a < n; ++a)
    if (!M.pinned[a]) trip.emplace_back(M.free_index[a], M.free_index[a], M.mass[a] / (M.h * M.h));
  for (int t = 0; t < T; ++t)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const int fa = M.free_index[M.tets[t][i]], fb = M.free_index[M.tets[t][j]];
        if (fa >= 0 && fb >= 0)
          trip.emplace_back(fa, fb, M.tet_weight[t] * factor * dot(M.shape_grad[4 * t + i], M.shape_grad[4 * t + j]));
      }
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < M.pair_count[j]; ++i)
      for (int k = 0; k < M.pair_count[j]; ++k) {
        const int fa = M.free_index[M.pair_vertex[j][i]], fb = M.free_index[M.pair_vertex[j][k]];
        if (fa >= 0 && fb >= 0) trip.emplace_back(fa, fb, M.k_svc * M.pair_weight[j][i] * M.pair_weight[j][k]);
      }
  Eigen::SparseMatrix<double> A(M.num_free, M.num_free);
  A.setFromTriplets(trip.begin(), trip.end());
  return A;
}

std::vector<double> l1_row_sums(const Eigen::SparseMatrix<double>& A) {
  std::vector<double> sum(A.rows(), 0.0);
  for (int c = 0; c < A.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, c); it; ++it) sum[it.row()] += std::abs(it.value());
  return sum;
}

PhysicalModel build_physical_model(const Scene& scene, const VirtualModel* virtual_model,
                                   const PhysicalModelOptions& options) {
  const TetMesh& mesh = scene.physical;
  const std::string where = scene.spec.file.string();
  PhysicalModel M;
  M.num_vertices = static_cast<int>(mesh.vertices.size());
  M.num_tets = static_cast<int>(mesh.tets.size());
  M.h = options.h;
  M.k_vol = scene.spec.stiffness.k_vol;
  M.k_det = scene.spec.stiffness.k_det;
  M.det_ratio = M.k_det / M.k_vol;
  M.k_svc = scene.spec.stiffness.k_svc;
  M.damping = scene.spec.damping;
  M.gravity = scene.spec.gravity;
  M.rest = mesh.vertices;
  M.tets = mesh.tets;
  if (!(M.h > 0)) throw InputError(where + ": physical step must be positive");
  const int n = M.num_vertices, T = M.num_tets;

  // Per tet: rest volume, PD weight, shape gradients.
  M.volume.resize(T);
  // Each tet's k_vol (Scene::tet_k_vol); none given, or a mesh put in the scene's place in code
  // while it has no stiffness.regions: stiffness.k_vol for all.
  const bool per_tet = static_cast<int>(scene.tet_k_vol.size()) == T;
  if (!per_tet && !scene.spec.stiffness_regions.empty())
    throw InputError(where + ": " + std::to_string(scene.tet_k_vol.size()) + " tet stiffnesses (stiffness.regions) for " +
                     std::to_string(T) + " tets: the physical mesh changed after the scene was built");
  M.tet_k_vol = per_tet ? scene.tet_k_vol : std::vector<double>(T, M.k_vol);
  M.tet_weight.resize(T);
  M.shape_grad.resize(4 * size_t(T));
  for (int t = 0; t < T; ++t) {
    for (int c = 0; c < 4; ++c)
      if (M.tets[t][c] < 0 || M.tets[t][c] >= n)
        throw InputError(where + ": tet " + std::to_string(t) + " names vertex " + std::to_string(M.tets[t][c]) +
                         " of " + std::to_string(n));
    const Vec3d& X0 = M.rest[M.tets[t][0]];
    const Mat3d Dm = Mat3d::from_cols(M.rest[M.tets[t][1]] - X0, M.rest[M.tets[t][2]] - X0, M.rest[M.tets[t][3]] - X0);
    const double det = determinant(Dm);
    const double scale = std::pow(frobenius_sq(Dm) / 3.0, 1.5);  // ~ edge length^3
    if (!(std::abs(det) > 1e-12 * scale))
      throw InputError(where + ": tet " + std::to_string(t) + " has zero rest volume");
    M.volume[t] = std::abs(det) / 6.0;
    M.tet_weight[t] = arap_weight(M.tet_k_vol[t], M.volume[t]);
    tet_shape_gradients(inverse(Dm), &M.shape_grad[4 * size_t(t)]);
  }
  M.density = scene.spec.density;
  M.mass = lumped_masses(mesh, scene.spec.density);

  // Pinned and free vertices.
  M.pinned.assign(n, 0);
  for (int p : scene.pinned) {
    if (p < 0 || p >= n) throw InputError(where + ": pinned vertex " + std::to_string(p) + " out of range");
    M.pinned[p] = 1;
  }
  M.free_index.assign(n, -1);
  for (int a = 0; a < n; ++a)
    if (!M.pinned[a]) { M.free_index[a] = static_cast<int>(M.free_vertices.size()); M.free_vertices.push_back(a); }
  M.num_free = static_cast<int>(M.free_vertices.size());
  double w2 = 0;
  for (int a : M.free_vertices) w2 += (M.mass[a] * kStandardGravity) * (M.mass[a] * kStandardGravity);
  // The residual's scale, in the weights of soft tissue's lowest density at least: a mesh all but
  // weightless (material.density 1e-9, warned at load) leaves billions of its own weights
  // unbalanced where a tissue's would see a fraction of one (tube_insert in contact: 4.5e9, 0.045
  // of those), and its motion is the tissue's. The stopping rule, the recovery, the health check
  // and the warnings all read the residual in this scale.
  const double lightness = M.density > 0 && M.density < kTissueDensityMin ? kTissueDensityMin / M.density : 1.0;
  M.weight_norm = std::sqrt(w2) * lightness;
  if (n > 0) {
    Vec3d lo = M.rest[0], hi = M.rest[0];
    for (const Vec3d& p : M.rest) { lo = cwise_min(lo, p); hi = cwise_max(hi, p); }
    M.rest_diagonal = norm(hi - lo);
  }

  // Incidence vertex -> (tet, corner), in (tet, corner) order.
  build_csr(n, 4 * T, [&](int e, auto add) { add(M.tets[e >> 2][e & 3]); }, M.tet_offsets, M.tet_entries);

  // The local order and the local step's structure-of-arrays copies by slot.
  set_local_order(M, options.local_order);

  // E_svc coupling and its reverse (physical -> virtual) list.
  if (virtual_model) {
    M.num_virtual = virtual_model->num_vertices;
    M.pair_vertex = virtual_model->pair_vertex;
    M.pair_weight = virtual_model->pair_weight;
    M.pair_count = virtual_model->pair_count;
  }
  const int m = M.num_virtual;
  std::vector<int> slot_entries;
  build_csr(n, 4 * m,
            [&](int e, auto add) { if ((e & 3) < M.pair_count[e >> 2]) add(M.pair_vertex[e >> 2][e & 3]); },
            M.cpl_offsets, slot_entries);
  M.cpl_virtual.resize(slot_entries.size());
  M.cpl_weight.resize(slot_entries.size());
  for (size_t k = 0; k < slot_entries.size(); ++k) {
    M.cpl_virtual[k] = slot_entries[k] >> 2;
    M.cpl_weight[k] = M.pair_weight[slot_entries[k] >> 2][slot_entries[k] & 3];
  }

  // The global matrix over free vertices: its diagonal (plain or bounded) and, for the direct
  // method, its factorisation.
  const Eigen::SparseMatrix<double> A = assemble_global_matrix(M);
  M.diag.assign(n, 0.0);
  const double factor = volume_matrix_factor(M.det_ratio);  // E_det's share of a tet's weight
  for (int a = 0; a < n; ++a) {  // pinned rows: the plain diagonal (never used by the update)
    double d = M.mass[a] / (M.h * M.h);
    for (int k = M.tet_offsets[a]; k < M.tet_offsets[a + 1]; ++k) {
      const int e = M.tet_entries[k];
      d += M.tet_weight[e >> 2] * factor * squared_norm(M.shape_grad[e]);
    }
    for (int k = M.cpl_offsets[a]; k < M.cpl_offsets[a + 1]; ++k) d += M.k_svc * M.cpl_weight[k] * M.cpl_weight[k];
    M.diag[a] = d;
  }
  choose_diagonal(M, A, options.diagonal);
  set_local_arrays(M);
  if (options.factorize && M.num_free > 0) M.direct = factorize_global_matrix(A, where);
  return M;
}

std::shared_ptr<const PhysicalDirectSolver> factorize_global_matrix(const Eigen::SparseMatrix<double>& A,
                                                                    const std::string& where) {
  auto solver = std::make_shared<PhysicalDirectSolver>();
  solver->ldlt.compute(A);
  if (solver->ldlt.info() != Eigen::Success)
    throw InputError(where + ": the physical mesh's global matrix is not positive definite");
  return solver;
}

PhysicalState make_physical_state(const PhysicalModel& model) {
  PhysicalState s;
  s.x = model.rest;
  s.v.assign(model.num_vertices, Vec3d{});
  s.rotation.assign(model.num_tets, Quatd{});
  return s;
}

PhysicalWorkspace make_physical_workspace(const PhysicalModel& model) {
  PhysicalWorkspace ws;
  const size_t n = model.num_vertices;
  ws.x.assign(n, Vec3d{});
  ws.s.assign(n, Vec3d{});
  ws.x_start.assign(n, Vec3d{});
  ws.x_prev.assign(n, Vec3d{});
  ws.r.assign(n, Vec3d{});
  ws.tet_force.assign(4 * size_t(model.num_tets), Vec3d{});
  ws.cpl_force.assign(model.num_virtual, Vec3d{});
  ws.rhs.setZero(model.num_free, 3);
  ws.dx.setZero(model.num_free, 3);
  return ws;
}

double chebyshev_rate_rho(const PhysicalModel& model, double gamma) {
  return std::clamp(model.spectrum.jacobi_rate(gamma), 0.5, 0.9999);
}

double chebyshev_rho_of(const SolverSpec& spec, const PhysicalModel& model, double gamma) {
  return spec.chebyshev_rho_auto ? chebyshev_rate_rho(model, gamma) : spec.chebyshev_rho;
}

PhysicalStepParams physical_params(const SolverSpec& spec, const PhysicalModel& model) {
  PhysicalStepParams p;
  p.method = spec.method;
  p.iterations = spec.physical_iterations;
  p.chebyshev_rho = chebyshev_rho_of(spec, model, p.relaxation);
  p.tolerance = spec.physical_tolerance;
  p.max_iterations = std::max(spec.physical_max_iterations, spec.physical_iterations);
  return p;
}

PhysicalModelOptions physical_model_options(const SceneSpec& spec) {
  PhysicalModelOptions o;
  o.h = 1.0 / spec.physical_hz;
  o.factorize = spec.solver.method == SolverSpec::Method::Direct;
  o.diagonal = spec.solver.diagonal;
  return o;
}

PhysicalStepReport physical_step(const PhysicalModel& model, PhysicalWorkspace& ws, PhysicalState& state,
                                 std::span<const Vec3d> virtual_q, const PhysicalStepParams& params,
                                 const PhysicalDirectSolver* direct, SharedLoops* shared,
                                 const PhysicalRegion* region, const std::function<bool()>& cancel) {
  const auto t_step = Clock::now();
  PhysicalStepReport report;
  if (model.num_virtual > 0 && virtual_q.size() != size_t(model.num_virtual))
    throw std::invalid_argument("physical_step: virtual_q has the wrong size");
  if (!direct) direct = model.direct.get();
  if (params.method == SolverSpec::Method::Direct && !direct && model.num_free > 0)
    throw std::invalid_argument("physical_step: direct method on a model built without factorisation");
  if (region && region->all) region = nullptr;  // every vertex: the whole mesh's step
  if (region && params.method == SolverSpec::Method::Direct)
    throw std::invalid_argument("physical_step: the direct method iterates every vertex (no awake region)");
  auto norm = [&] { return region ? region_residual_norm(ws, *region) : residual_norm(model, ws); };

  double r0 = 0, rk = 0;
  const int K = params.iterations;
  const bool adaptive = params.adaptive();
  const double tolerance = adaptive ? params.tolerance : 0.0;
  const int max_iterations = adaptive ? params.max_iterations : K;
  const double weight_scale = model.weight_norm > 0 ? model.weight_norm : 1.0;  // set_residuals' scale
  int iterations = 0;
  StoppingState stopping;
  bool more = false;  // the rule's decision, made by one thread
  bool cancelled = false;  // the cancel flag as one thread read it
  // One parallel region for the whole step: the stages are work-sharing loops with two barriers
  // per iteration. The master thread times the stages and sums the residual norms (after the
  // barrier ending the global step; ws.r is next written after the following local step's barrier).
  // From iteration K - 1 on one thread sums the norm and decides for all (a third barrier).
  // With `shared` one thread runs it all and the stages' loops are shared with a helper.
#pragma omp parallel if (shared == nullptr)
  {
    predict(model, ws, state, region, shared);
    double omega = 1;  // every thread follows the same Chebyshev weights
    for (int k = 0; k < max_iterations; ++k) {
      auto t0 = Clock::now();
      local_step(model, ws, state, virtual_q, params, region, shared);
#pragma omp master
      {
        report.local_s += seconds_since(t0);
        t0 = Clock::now();
      }
      omega = chebyshev_weight(params, k, omega);
      residual_and_update(model, ws, params.method, params.relaxation, omega, region, shared);
      if (params.method == SolverSpec::Method::Direct) {
#pragma omp single
        global_direct(model, *direct, ws);  // implicit barrier
      }
      if (k + 1 < K) {
#pragma omp master
        {
          if (k == 0) r0 = norm();
          report.global_s += seconds_since(t0);
        }
        if (cancel && k % kCancelPollIterations == kCancelPollIterations - 1) {
#pragma omp single
          {
            cancelled = cancel();
            iterations = k + 1;
          }  // implicit barrier: every thread reads the same
          if (cancelled) break;
        }
        continue;
      }
#pragma omp single
      {
        rk = norm();
        if (k == 0) r0 = rk;
        iterations = k + 1;
        more = continue_iterating(k, rk / weight_scale, K, tolerance, max_iterations, stopping);
        if (more && cancel && cancel()) more = !(cancelled = true);
        report.global_s += seconds_since(t0);
      }  // implicit barrier: every thread reads the same decision (next written after the next local step)
      if (!more) break;
    }
    update_velocities(model, ws, state, shared);
  }
  report.iterations = iterations;
  report.cancelled = cancelled;
  set_residuals(report, r0, rk, model.weight_norm);
  report.time_s = seconds_since(t_step);
  return report;
}

std::string physical_state_problem(const PhysicalModel& model, std::span<const Vec3d> x,
                                   const PhysicalStepReport& report) {
  constexpr double kDivergedExtent = 10.0;  // bounding-box diagonals
  constexpr double kDivergedResidual = 1e4;  // mesh weights
  constexpr double kStillExtent = 1e-4;      // bounding-box diagonals
  if (model.num_vertices == 0) return "";
  int worst = 0;
  double moved2 = 0;  // squared: one square root for the worst vertex only
  for (int a = 0; a < model.num_vertices; ++a) {
    const double d2 = squared_norm(x[a] - model.rest[a]);
    if (!(d2 <= moved2)) {  // also takes NaN, and stops there
      worst = a;
      moved2 = d2;
      if (!std::isfinite(d2)) break;
    }
  }
  const double moved = std::sqrt(moved2), diagonal = model.rest_diagonal;
  std::string what;
  if (!std::isfinite(moved)) what = "is not finite";
  else if (moved > kDivergedExtent * diagonal) what = "diverged";
  else if (!std::isfinite(report.residual) || report.residual > kDivergedResidual)
    // A residual that large with the mesh all but still (float32 round-off at an extreme stiffness
    // on the CUDA backend) is a solve that did not converge, not a mesh that flew apart.
    what = moved > kStillExtent * diagonal || !std::isfinite(report.residual) ? "diverged" : "did not converge";
  if (what.empty()) return "";
  // The worst-shaped tet around the worst vertex (rest mean ratio).
  int tet = -1;
  double quality = 2;
  for (int k = model.tet_offsets[worst]; k < model.tet_offsets[worst + 1]; ++k) {
    const int t = model.tet_entries[k] >> 2;
    const Tet& c = model.tets[t];
    const double q = tet_mean_ratio(model.rest[c[0]], model.rest[c[1]], model.rest[c[2]], model.rest[c[3]]);
    if (q < quality) { quality = q; tet = t; }
  }
  char line[512];
  std::snprintf(line, sizeof line,
                "the physical mesh %s (residual %.3g mesh weights): vertex %d (rest [%.6g, %.6g, %.6g] m) moved %.3g m; "
                "its worst tet %d has mean ratio %.3g",
                what.c_str(), report.residual, worst, model.rest[worst].x, model.rest[worst].y, model.rest[worst].z,
                moved, tet, tet >= 0 ? quality : 0.0);
  return line;
}

PhysicalEnergy physical_energy(const PhysicalModel& model, std::span<const Vec3d> x, std::span<const Vec3d> s,
                               std::span<const Vec3d> virtual_q) {
  PhysicalEnergy E;
  for (int t = 0; t < model.num_tets; ++t) {
    const Tet& tet = model.tets[t];
    const Vec3d xc[4] = {x[tet[0]], x[tet[1]], x[tet[2]], x[tet[3]]};
    const Mat3d F = deformation_gradient(xc, &model.shape_grad[4 * t]);
    E.volume += arap_energy(F, polar_rotation_svd(F), model.tet_k_vol[t], model.volume[t]);
    // E_det's stiffness keeps its ratio to the tet's k_vol (det_ratio: the scene's k_det / k_vol);
    // a tet of the scene's k_vol takes k_det itself (k_det / k_vol x k_vol need not round back to it)
    const double k_det = model.tet_k_vol[t] == model.k_vol ? model.k_det : model.det_ratio * model.tet_k_vol[t];
    if (model.k_det > 0) E.volume += volume_energy(F, k_det, model.volume[t]);
  }
  if (!s.empty())
    for (int a = 0; a < model.num_vertices; ++a) E.inertia += inertia_energy(x[a], s[a], model.mass[a], model.h);
  if (!virtual_q.empty())
    for (int j = 0; j < model.num_virtual; ++j) {
      const Vec3d p = paired_point(x.data(), model.pair_vertex[j].data(), model.pair_weight[j].data(), model.pair_count[j]);
      E.coupling += coupling_energy(p, virtual_q[j], model.k_svc);
    }
  return E;
}

void physical_elastic_forces(const PhysicalModel& model, std::span<const Vec3d> x, std::span<Vec3d> forces) {
  const int n = model.num_vertices;
#pragma omp parallel for schedule(static)
  for (int a = 0; a < n; ++a) {
    Vec3d f{};
    for (int k = model.tet_offsets[a]; k < model.tet_offsets[a + 1]; ++k) {
      const int e = model.tet_entries[k], t = e >> 2;
      const Tet& tet = model.tets[t];
      const Vec3d xc[4] = {x[tet[0]], x[tet[1]], x[tet[2]], x[tet[3]]};
      const Mat3d F = deformation_gradient(xc, &model.shape_grad[4 * t]);
      f += elastic_force_matrix(F, polar_rotation_svd(F), model.tet_weight[t], model.det_ratio) * model.shape_grad[e];
    }
    forces[a] = f;
  }
}

double float32_residual_floor(const PhysicalModel& model, const Vec3d& origin) {
  // The device step's arithmetic at rest, in float: positions and shape gradients rounded, one
  // warm-started rotation update from R = I, the corner forces summed per vertex.
  const auto f32 = [](const Vec3d& v) { return Vec3f{float(v.x), float(v.y), float(v.z)}; };
  std::vector<Vec3f> x(model.rest.size());
  for (std::size_t a = 0; a < x.size(); ++a) x[a] = f32(model.rest[a] - origin);
  double r2 = 0;
#pragma omp parallel for schedule(static) reduction(+ : r2)
  for (int i = 0; i < model.num_free; ++i) {
    const int a = model.free_vertices[i];
    Vec3f f{};
    for (int k = model.tet_offsets[a]; k < model.tet_offsets[a + 1]; ++k) {
      const int e = model.tet_entries[k], t = e >> 2;
      const Tet& tet = model.tets[t];
      const Vec3f xc[4] = {x[tet[0]], x[tet[1]], x[tet[2]], x[tet[3]]};
      const Vec3f g[4] = {f32(model.shape_grad[4 * t]), f32(model.shape_grad[4 * t + 1]),
                          f32(model.shape_grad[4 * t + 2]), f32(model.shape_grad[4 * t + 3])};
      const Mat3f F = deformation_gradient(xc, g);
      float angle = 0;
      const Mat3f R = rotation_matrix(mueller_update(F, Quat<float>{1, 0, 0, 0}, angle));
      f += elastic_force_matrix(F, R, float(model.tet_weight[t]), float(model.det_ratio)) * g[e & 3];
    }
    r2 += double(f.x) * f.x + double(f.y) * f.y + double(f.z) * f.z;
  }
  return model.weight_norm > 0 ? std::sqrt(r2) / model.weight_norm : std::sqrt(r2);
}

std::string double_round_off_cause(const SceneSpec& spec, const PhysicalModel& model) {
  const Vec3d c = bounding_box(model.rest).centre();
  const double distance = norm(c), size = model.rest_diagonal;
  const double round_off = 0.5 * std::numeric_limits<double>::epsilon() * distance;  // m, of a position
  if (!(round_off > kDoubleRoundOffShare * size)) return "";
  char line[320];
  std::snprintf(line, sizeof line,
                "the physical mesh's centre lies %.3g m from the world's origin, %.2g times its size, where double's "
                "round-off of its positions (%.2g m) can leave what they stall at: move the mesh near the origin "
                "(mesh.transform.translate: ",
                distance, distance / size, round_off);
  return line + translate_to_origin(spec, c) + ") and the recording's poses by as much";
}

std::string float32_placement_warning(const SceneSpec& spec, const PhysicalModel& model, double floor) {
  const double tolerance = spec.solver.physical_tolerance;
  if (!(tolerance > 0 && floor > tolerance)) return "";
  const Vec3d c = bounding_box(model.rest).centre();
  const double centred = float32_residual_floor(model, c);
  if (!(floor > 4 * centred)) return "";  // the mesh's own floor (fine tets, slivers), not its place
  const std::string translate = translate_to_origin(spec, c);
  char line[640];
  std::snprintf(line, sizeof line,
                ": the physical mesh's centre lies %.3g m from the world's origin, where the CUDA backend's float32 "
                "positions round to %.2g mesh weights of residual (%.2g with the mesh at the origin%s), above "
                "solver.physical_tolerance %.3g: the device's steps run until they stall; move the mesh to the "
                "origin (mesh.transform.translate: %s) and the log with it (replay --transform)",
                norm(c), floor, centred, centred > tolerance ? ", still above it: its tets are too fine or flat for float32" : "",
                tolerance, translate.c_str());
  return spec.physical_mesh.string() + line;
}

}  // namespace ebh
