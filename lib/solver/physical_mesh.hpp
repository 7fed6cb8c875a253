#pragma once
// The physical mesh under Projective Dynamics (paper §4.2, Algorithm 1): a tet mesh minimising
//     E_soft = E_vol + E_k + E_svc      (E_con acts on the virtual mesh only)
// by local-global iterations. The global matrix
//     A = M / h^2 + sum_t w_t G_t^T G_t + k_svc sum_j w_j w_j^T     (n x n, the same for x, y, z)
// is constant, so one step reads (physical_step):
//     predict         s = x + h v + h^2 g, x <- x + h v                Alg. 1 line 1-2 (x_0: docs/MODEL.md)
//     for k < K:
//       local step    R_t = polar(F_t) per tet; E_svc forces per pair  Alg. 1 lines 6-8
//       residual      r = -grad E at x (gathered per vertex)
//       global step   jacobi | chebyshev | direct on A dx = r          Alg. 1 line 9
//     velocities      v = (1 - damping) (x - x_start) / h              Alg. 1 line 11
// Pinned vertices have no row in the system: they never move.
//
// Determinism: per-tet and per-virtual-vertex loops write their own slot, per-vertex loops gather
// over CSR lists in a fixed order, and norms are summed serially: the result is bitwise identical
// for any OpenMP thread count. Tets go through the local step in fixed blocks of SIMD lanes
// (solver/local_kernels.hpp), so a tet takes the same code path whatever the thread count.
//
// Speed (docs/MODEL.md, "Implementation"): one OpenMP parallel region per step with two barriers
// per iteration (after the local step, after the global step); the local step writes each tet's
// four corner forces w_t (R_t - F_t) g_c, and the per-vertex gather of them is fused with the
// Jacobi/Chebyshev update.
#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "math/hd.hpp"
#include "math/vec.hpp"
#include "mesh/tet_mesh.hpp"
#include "scene/scene.hpp"
#include "solver/spectrum.hpp"

namespace ebh {

struct VirtualModel;
struct PhysicalRegion;
class SharedLoops;

/// The exact global solve: A restricted to free vertices, factorised once per topology.
struct PhysicalDirectSolver {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
};

/// The per-vertex data of the CPU step by local index i (PhysicalModel::vertex_order[i] is the
/// file's vertex): the file order's values and incidence lists, each list in the file order's
/// entry order, with vertex indices local.
struct PhysicalLocalArrays {
  std::vector<double> mass, diag;              ///< #n PhysicalModel::mass, diag
  std::vector<std::uint8_t> pinned;            ///< #n
  std::vector<int> tet_offsets;                ///< #n+1 CSR -> the vertex's (tet, corner) entries, as tet_entries
  std::vector<int> force_entries;              ///< 4 tet_slot[t] + c for each entry 4 t + c: where tet_force holds it
  std::vector<int> cpl_offsets;                ///< #n+1 CSR -> (virtual vertex, weight), as cpl_offsets
  std::vector<int> cpl_virtual;                ///< virtual-vertex index
  std::vector<double> cpl_weight;              ///< its weight on this physical vertex
  std::vector<std::array<int, 4>> pair_vertex; ///< #m local indices of the physical vertices each virtual vertex pairs with
  std::vector<int> free_vertices;              ///< #nf local index of PhysicalModel::free_vertices[i] (the direct solve's row i)
};

/// Immutable physical-mesh model. n = #vertices, T = #tets, m = #virtual vertices, nf = #free.
struct PhysicalModel {
  int num_vertices = 0;                 ///< n
  int num_tets = 0;                     ///< T
  int num_free = 0;                     ///< nf, vertices that are not pinned
  int num_virtual = 0;                  ///< m, 0 when there is no E_svc coupling
  double h = 0;                         ///< physical step (s)
  double k_vol = 0;                     ///< Pa, E_vol [7]: the scene's (stiffness.k_vol); tet_k_vol per tet
  double k_det = 0;                     ///< Pa, E_det (energy/volume.hpp); 0 = the paper's model
  double det_ratio = 0;                 ///< kappa = k_det / k_vol
  double k_svc = 0;                     ///< N/m, E_svc [5]
  double damping = 0;                   ///< fraction of velocity removed per step
  Vec3d gravity;                        ///< m/s^2
  std::vector<Vec3d> rest;              ///< #n rest positions, metres
  std::vector<Tet> tets;                ///< #T
  std::vector<double> volume;           ///< #T rest volume V_t, m^3
  std::vector<double> tet_k_vol;        ///< #T the tet's k_vol (Scene::tet_k_vol: stiffness.regions)
  std::vector<double> tet_weight;       ///< #T w_t = 2 k_vol_t V_t
  std::vector<Vec3d> shape_grad;        ///< #T*4 g_c with F = sum_c x_c g_c^T (1/m)
  std::vector<double> mass;             ///< #n lumped mass, kg (density V_t / 4 per corner)
  double density = 0;                   ///< kg/m^3, the masses' (material.density)
  double weight_norm = 0;               ///< ||M g0|| over free vertices (N), g0 = 9.81 m/s^2, M at 100 kg/m^3 at least: the residual's scale
  double rest_diagonal = 0;             ///< m, the rest shape's bounding-box diagonal (the health check's scale)
  std::vector<std::uint8_t> pinned;     ///< #n
  std::vector<int> free_index;          ///< #n row among free vertices, -1 when pinned
  std::vector<int> free_vertices;       ///< #nf
  std::vector<int> tet_offsets;         ///< #n+1 CSR vertex -> incident (tet, corner)
  std::vector<int> tet_entries;         ///< 4 t + c
  // E_svc coupling: virtual vertex j pairs with sum_k w_jk x_{i_jk} (copied from VirtualModel).
  std::vector<std::array<int, 4>> pair_vertex;     ///< #m
  std::vector<std::array<double, 4>> pair_weight;  ///< #m
  std::vector<int> pair_count;                     ///< #m
  std::vector<int> cpl_offsets;         ///< #n+1 CSR physical vertex -> (virtual vertex, weight)
  std::vector<int> cpl_virtual;         ///< virtual-vertex index
  std::vector<double> cpl_weight;       ///< its weight on this physical vertex
  /// #n the Jacobi-type methods' D(a): A(a, a) (plain, the paper's), or with the bounded diagonal
  /// max(A(a, a), theta D_l1(a)), D_l1(a) = sum_b |A(a, b)|, with the smallest theta in [0, 1/2]
  /// that keeps lambda_max(D^-1 A) <= 2.1 (a Lanczos estimate with a 2% margin). theta = 1/2
  /// always does: D >= D_l1 / 2 >= A / 2 (D_l1 - A is diagonally dominant; Baker, Falgout, Kolev &
  /// Yang 2011, l1 smoothers), so the bound holds on every mesh; theta = 0 (good meshes: all the
  /// committed scenes) is the paper's diagonal to the bit. With the bound and gamma <= 0.95 the
  /// relaxed Jacobi update decreases the global step's quadratic energy and Chebyshev's error
  /// polynomial shrinks every mode; without it, obtuse and sliver tets push lambda_max past
  /// 2 / gamma and the iteration diverges.
  std::vector<double> diag;
  double diag_theta = 0;                ///< bounded: D = max(A(a, a), theta D_l1(a)); 0: A(a, a)
  int diag_bounded_rows = 0;            ///< rows where theta raised D above A(a, a)
  SpectrumEstimate spectrum;            ///< of D^-1 A with this D (solver/spectrum.hpp)
  // The CPU step's local order: the step numbers the vertices in Morton order of their rest
  // positions (local index i, vertex_order[i] the file's vertex) and visits the tets by slot, the
  // slots in Morton order of the tets' rest centroids, so that neighbouring vertices and tets sit
  // near each other in memory (cholecystectomy.msh numbers its vertices far apart in space). The
  // step copies x into the local order at its start, and x and v back at its end. The sums keep the
  // incidence lists' (tet, corner) order and the residual norm the file's vertex order, and the
  // last tets that do not fill a SIMD block keep their slots, so the step's bits are those of the
  // file's order.
  std::vector<int> tet_slot;            ///< #T slot of tet t (the identity with PhysicalModelOptions::local_order off)
  std::vector<int> vertex_order;        ///< #n the file's vertex at local index i (the identity with local_order off)
  std::vector<int> vertex_local;        ///< #n the local index of the file's vertex a
  PhysicalLocalArrays local;            ///< the per-vertex data the CPU step reads, by local index
  // The local step's structure-of-arrays copies (SIMD loads), by slot s = tet_slot[t]:
  std::vector<int> corner_soa;          ///< #4T local index of corner c of the tet in slot s at [c T + s]
  std::vector<double> shape_grad_soa;   ///< #9T component i of its g_c, c = 1..3, at [(3 c - 3 + i) T + s] (g_0: first_shape_gradient)
  std::vector<double> weight_soa;       ///< #T its w_t at [s]
  std::shared_ptr<const PhysicalDirectSolver> direct;  ///< null when not factorised
};

/// Mutable physical-mesh state.
struct PhysicalState {
  std::vector<Vec3d> x;         ///< #n positions, metres
  std::vector<Vec3d> v;         ///< #n velocities, m/s
  std::vector<Quatd> rotation;  ///< #T last rotation of each tet, by slot (PhysicalModel::tet_slot): the local step's warm start
};

/// Scratch of physical_step, sized once. Per-vertex arrays by local index (PhysicalModel::vertex_order).
struct PhysicalWorkspace {
  std::vector<Vec3d> x;          ///< #n the step's positions (PhysicalState::x in the local order; copied back at its end)
  std::vector<Vec3d> s;          ///< #n prediction (Alg. 1 line 1)
  std::vector<Vec3d> x_start;    ///< #n positions at the start of the step
  std::vector<Vec3d> x_prev;     ///< #n previous iterate (Chebyshev)
  std::vector<Vec3d> r;          ///< #n residual -grad E (0 on pinned vertices)
  std::vector<Vec3d> tet_force;  ///< #4T the local step's output w_t (R_t - F_t) g_c at [4 tet_slot[t] + c]
  std::vector<Vec3d> cpl_force;  ///< #m k_svc (q_j - p_j)
  Eigen::MatrixXd rhs;           ///< nf x 3 (direct)
  Eigen::MatrixXd dx;            ///< nf x 3 (direct)
};

struct PhysicalModelOptions {
  double h = 0.01;            ///< physical step (s); 1 / scene.spec.physical_hz by default
  bool factorize = true;      ///< build the direct solver (needed by Method::Direct)
  /// The Jacobi-type methods' diagonal D (see PhysicalModel::diag): bounded (convergent for every
  /// mesh) or plain (A(a, a), the paper's; diverges on meshes with obtuse and sliver tets).
  SolverSpec::Diagonal diagonal = SolverSpec::Diagonal::Bounded;
  /// The CPU step's local order (PhysicalModel::tet_slot); off: the file's order. The same bits
  /// either way; only the speed differs.
  bool local_order = true;
};

struct PhysicalStepParams {
  SolverSpec::Method method = SolverSpec::Method::Chebyshev;
  int iterations = 16;           ///< local-global iterations K
  double chebyshev_rho = 0.95;   ///< spectral-radius estimate (Wang 2015)
  double relaxation = 0.9;       ///< under-relaxation gamma of the Jacobi update (Wang 2015, the paper)
  int chebyshev_delay = 2;       ///< relaxed Jacobi iterations before the Chebyshev weights start
  int rotation_iterations = 1;   ///< Mueller 2016 updates per tet and local step (warm-started from the last iteration)
  /// The Jacobi-type methods' stopping rule (continue_iterating): past `iterations`, go on while
  /// the residual at the start of the last iteration is above `tolerance` mesh weights, up to
  /// `max_iterations` in all. 0: exactly `iterations` (and always for the direct method).
  double tolerance = 0;
  int max_iterations = 0;
  /// Whether the step may run past `iterations`.
  bool adaptive() const {
    return tolerance > 0 && iterations >= 1 && max_iterations > iterations && method != SolverSpec::Method::Direct;
  }
};

/// What the stopping rule remembers within a step: the best residual since iteration K - 1 (one
/// that beat the previous best by kStallGain) and its iteration (-1: none yet).
struct StoppingState {
  double best = 0;
  int best_k = -1;
};
/// The rule stops a step whose residual has not fallen below kStallGain times its best for
/// kStallIterations iterations: the iterations have stalled (float32's round-off floor on the
/// device, a Chebyshev rho far from the mesh's rate), so more of them would only cost time.
inline constexpr int kStallIterations = 8;
inline constexpr double kStallGain = 0.95;
/// A replay warns of steps that stalled with more than this many times the tolerance left
/// (ReplayWriter::stalled_steps): above float32's floor on the committed scenes (up to 0.0031
/// against 0.002 mesh weights), so that the device's ordinary stalls stay quiet.
inline constexpr double kStalledResidualFactor = 5;
/// On the device, a stall at most this many times float32_residual_floor is read as round-off: the
/// h200's steps stalled at 4.3-4.9 times it (tube, tube refined twice, gynaecology refined once),
/// slivers' at 25-30 times (no headway, as on the CPU).
inline constexpr double kFloat32StallFactor = 8;
/// A scene whose Chebyshev rho (a number or `auto`) is above this is warned at load: with the
/// weights near 2 the local-global iterations blew up on a sliver mesh from 0.997 (0.995 held; the
/// committed scenes' `auto` is 0.786-0.979, 0.986 at mean ratio 0.04; their number 0.95).
inline constexpr double kChebyshevRhoWarn = 0.99;

/// The stopping rule of the CPU step and the CUDA graph alike: after iteration k (0-based) whose
/// start left `residual` mesh weights unbalanced, run iteration k + 1? Always below `iterations`;
/// past it only while residual > tolerance, fewer than max_iterations have run, and the residual
/// has not stalled (StoppingState, updated here).
EBH_HD bool continue_iterating(int k, double residual, int iterations, double tolerance, int max_iterations,
                               StoppingState& state) {
  if (k + 1 < iterations) return true;
  if (state.best_k < 0 || residual < kStallGain * state.best) {
    state.best = residual;
    state.best_k = k;
  }
  return tolerance > 0 && k + 1 < max_iterations && residual > tolerance && k - state.best_k < kStallIterations;
}

/// The Chebyshev weight of iteration k given the previous one (Wang 2015: 1 for the first
/// chebyshev_delay iterations, then 2 / (2 - rho^2), then 4 / (4 - rho^2 omega_prev)); 1 for the
/// other methods. The CPU step and the CUDA graph both take their weights from here.
inline double chebyshev_weight(const PhysicalStepParams& params, int k, double previous) {
  if (params.method != SolverSpec::Method::Chebyshev) return 1.0;
  const double rho2 = params.chebyshev_rho * params.chebyshev_rho;
  const int j = k - params.chebyshev_delay;
  return j < 0 ? 1.0 : (j == 0 ? 2.0 / (2.0 - rho2) : 4.0 / (4.0 - rho2 * previous));
}

/// The step report (time in seconds of wall clock). r is -grad E_soft over free vertices at an
/// iterate (R from its local step): r_0 at the prediction, r_K at the start of the last iteration.
struct PhysicalStepReport {
  int iterations = 0;
  /// ||r_K|| / ||M g0|| (g0 = 9.81 m/s^2; both norms over the free vertices' 3-vectors): the force
  /// the step leaves unbalanced relative to the vertices' weights ("mesh weights" in messages).
  /// 0 at rest and at convergence, whatever the iterations did before.
  double residual = 0;
  /// ||r_K|| / ||r_0||: what the iterations of this step achieved (~1 at rest, where r_0 ~ 0).
  double residual_reduction = 0;
  double time_s = 0;
  double local_s = 0;   ///< local steps (rotations, coupling forces)
  double global_s = 0;  ///< residual gathers and global steps
  bool slept = false;   ///< skipped, the state held (solver.sleep, an empty awake region; iterations 0)
  int awake = -1;       ///< vertices iterated under solver.physical_region (-1: the region is off)
  /// Physical tets inverted or flat after the step (inverted_or_flat, against their signs at rest)
  /// where the backend counted them: the CUDA steps inside the tick launches. -1: not counted (the
  /// replay's observer counts them on the host, InvertedTets).
  int inverted = -1;
  /// Stopped by its cancel flag (physical_step): the state is partway and not a result.
  bool cancelled = false;
};

/// The report's residuals from ||r_0|| and ||r_K|| (CPU and CUDA steps alike).
inline void set_residuals(PhysicalStepReport& report, double r0, double rk, double weight_norm) {
  report.residual = weight_norm > 0 ? rk / weight_norm : rk;
  report.residual_reduction = r0 > 0 ? rk / r0 : 0.0;
}

/// Builds the physical model of a scene. virtual_model: the E_svc pairing (null: no coupling).
/// Throws InputError for a degenerate tet (zero rest volume) or a bad index.
PhysicalModel build_physical_model(const Scene& scene, const VirtualModel* virtual_model,
                                   const PhysicalModelOptions& options);

PhysicalState make_physical_state(const PhysicalModel& model);  ///< rest, at rest, R = I
PhysicalWorkspace make_physical_workspace(const PhysicalModel& model);
/// The step's parameters from the scene's solver: Chebyshev's rho (chebyshev_rho_of), the
/// stopping rule's cap raised to K when below it.
PhysicalStepParams physical_params(const SolverSpec& spec, const PhysicalModel& model);
/// Chebyshev's rho on `model` for the scene's solver.chebyshev_rho: the number as it is, or for
/// `auto` the relaxed Jacobi iteration's spectral radius on the mesh (chebyshev_rate_rho).
double chebyshev_rho_of(const SolverSpec& spec, const PhysicalModel& model, double gamma);
/// The relaxed Jacobi iteration's spectral radius on `model`, max |1 - gamma lambda| over the
/// Lanczos estimate of the spectrum of D^-1 A (lambda_min an upper bound, so the rate is at most
/// the true one: Chebyshev's polynomial then still shrinks every mode), kept in [0.5, 0.9999].
double chebyshev_rate_rho(const PhysicalModel& model, double gamma);
PhysicalModelOptions physical_model_options(const SceneSpec& spec);  ///< h, the diagonal

/// The global matrix A over free vertices (nf x nf, rows in free_vertices order; the same for x,
/// y and z): what the direct method factorises and the Jacobi-type methods' diagonal comes from.
Eigen::SparseMatrix<double> assemble_global_matrix(const PhysicalModel& model);
/// sum_b |A(a, b)| per row (D_l1): D_l1 - A is diagonally dominant with a non-negative diagonal,
/// so D_l1 >= A for every symmetric A.
std::vector<double> l1_row_sums(const Eigen::SparseMatrix<double>& A);

/// The direct method's factorisation of A (assemble_global_matrix). Throws InputError naming
/// `where` when A is not positive definite.
std::shared_ptr<const PhysicalDirectSolver> factorize_global_matrix(const Eigen::SparseMatrix<double>& A,
                                                                    const std::string& where);

/// One physical step (Algorithm 1), in place on state.
///   virtual_q: #m virtual-mesh positions held fixed for E_svc (empty when num_virtual == 0).
///   direct: the factorisation the direct method uses (null: model.direct).
///   shared: run on the calling thread alone, the stages' loops shared with a thread that helps
///     (SharedLoops::help_until); null: an OpenMP team. The same bits either way.
///   region: iterate its awake vertices only (solver/physical_region.hpp: choose_awake decided
///     them; the others are held, v = 0; the Jacobi-type methods); null or all: every vertex.
PhysicalStepReport physical_step(const PhysicalModel& model, PhysicalWorkspace& ws, PhysicalState& state,
                                 std::span<const Vec3d> virtual_q, const PhysicalStepParams& params,
                                 const PhysicalDirectSolver* direct = nullptr, SharedLoops* shared = nullptr,
                                 const PhysicalRegion* region = nullptr, const std::function<bool()>& cancel = {});
/// `cancel`: asked every kCancelPollIterations iterations (one thread asks, all follow: a barrier
/// each time); when it says so the step stops there with report.cancelled (a run that ends, or is
/// interrupted, while a long step runs).
inline constexpr int kCancelPollIterations = 64;

struct PhysicalEnergy {
  double volume = 0;    ///< E_vol [7] (and E_det, energy/volume.hpp, where k_det > 0)
  double inertia = 0;   ///< E_k [6]
  double coupling = 0;  ///< E_svc [5]
  double total() const { return volume + inertia + coupling; }
};

/// E_soft at x (#n), R from the SVD polar decomposition. s: #n predictions (empty: no E_k);
/// virtual_q: #m (empty: no E_svc).
PhysicalEnergy physical_energy(const PhysicalModel& model, std::span<const Vec3d> x, std::span<const Vec3d> s,
                               std::span<const Vec3d> virtual_q);

/// The health check after a step (STYLE.md's run-time tier): "" when x (#n) is finite and has not
/// diverged, else one line naming the worst vertex and the worst-shaped tet around it. Diverged:
/// a vertex farther from its rest position than 10 times the mesh's bounding-box diagonal, or
/// report.residual above 1e4 (an unbalanced force of 10^4 times the mesh's weight); with no vertex
/// moved more than 1e-4 diagonals, that residual is said as "did not converge".
std::string physical_state_problem(const PhysicalModel& model, std::span<const Vec3d> x,
                                   const PhysicalStepReport& report);

/// Elastic forces -dE_vol/dx (#n, pinned vertices included: their reaction) at x (#n).
void physical_elastic_forces(const PhysicalModel& model, std::span<const Vec3d> x, std::span<Vec3d> forces);

/// The residual (mesh weights) of the rest shape with its positions rounded to float32: what the
/// CUDA step's float32 positions leave unbalanced where nothing moves, so about the lowest residual
/// its iterations reach. It grows as the mesh is refined (~1/h^2: the elastic forces of a position
/// error over an edge h, against a vertex weight ~h^3 and forces ~h), and with the mesh's distance
/// from the origin (float32 keeps 24 bits of each coordinate: a mesh 1 m away rounds 60 times
/// coarser than one 20 mm away). `origin`: the point the positions are rounded relative to
/// (the mesh's centre: the floor of the mesh alone).
double float32_residual_floor(const PhysicalModel& model, const Vec3d& origin = {});

/// A position at a distance d from the world's origin is rounded to eps/2 d in double (eps =
/// 2^-52). Above this share of the physical mesh's size (its rest bounding-box diagonal), that
/// round-off is named as a likely cause of steps that stall: measured, tube (100 mm, edges about
/// 3 mm) stalls above 5 times the default tolerance 1e9 m away (its positions rounded to 1.1e-6 of
/// its size), not 1e8 m away (1.1e-7); the residual grows as the round-off over the square of an
/// edge (float32_residual_floor), so edges 100 times finer, or slivers, stall at 1e-4 of that:
/// 1.1e-10, a centre about 1e6 sizes away.
inline constexpr double kDoubleRoundOffShare = 1e-10;

/// The cause to name first where the CPU step's iterations stalled: a physical mesh so far from
/// the world's origin against its size (kDoubleRoundOffShare) that double's round-off of its
/// positions can leave what they stall at, with the fix (translate_to_origin). "" where the mesh
/// lies near enough.
std::string double_round_off_cause(const SceneSpec& spec, const PhysicalModel& model);

/// The warning of a physical mesh so far from the world's origin that the CUDA backend's float32
/// positions leave a residual floor above solver.physical_tolerance (`floor`:
/// float32_residual_floor at the origin), where the mesh at the origin would not (a quarter of it
/// at most): a segmentation left in its scanner's coordinates. "" where there is nothing to say.
/// build_world says it for the CUDA backend; `ebh scene info` beside the floor.
std::string float32_placement_warning(const SceneSpec& spec, const PhysicalModel& model, double floor);

}  // namespace ebh
