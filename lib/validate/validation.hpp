#pragma once
// Validation cases with analytic or reference answers, run from the command line
// (`ebh validate NAME`, README.md) and by the tests.
//
// Adding one: write lib/validate/NAME.cpp defining `Validation NAME_validation()`, declare it
// below, and add it to the table in registry.cpp (one line each; static self-registration would
// be dropped by the linker from a static library, hence the table).
#include <functional>
#include <string>
#include <vector>

#include "io/json.hpp"

namespace ebh {

struct ValidationResult {
  std::string name;
  double error = 0;      ///< relative error of the checked quantity
  double tolerance = 0;  ///< passed when error <= tolerance (and any extra criterion in `data`)
  bool passed = false;
  Json data;             ///< the numbers behind the verdict (inputs, measured, expected, curves)
  /// The verdict in words where error and tolerance are counts, not a relative error (stability:
  /// "0 of 18 cases non-finite or blown up"); `ebh validate` prints it in their place.
  std::string summary;
  Json to_json() const;
};

/// What `ebh validate` passes to a case. `ebh validate` refuses --recording, --full, --backend
/// cuda and --set when no chosen case uses them (Validation::replays_recordings, has_full_form,
/// places_solvers: the stress matrices, which replay the recordings' scenes, take --set too).
struct ValidationOptions {
  bool full = false;            ///< the long form of a stress matrix (--full)
  std::string backend = "cpu";  ///< cpu | cuda (--backend)
  std::vector<std::string> recordings;  ///< replaces a stress matrix's recordings (--recording)
  /// scene overrides (--set KEY=VALUE) applied to every scene a stress matrix replays, before the
  /// case's own (the key the matrix varies keeps the matrix's value)
  std::vector<std::string> overrides;
};

struct Validation {
  std::string name;
  std::string description;  ///< one line: what is compared with what
  std::function<ValidationResult(const ValidationOptions&)> run;
  bool replays_recordings = false;  ///< takes ValidationOptions::recordings (--recording)
  bool has_full_form = false;       ///< reads ValidationOptions::full (--full)
  bool places_solvers = false;      ///< runs its iterative solvers on ValidationOptions::backend (--backend)
  /// The scene keys its matrix varies: a --set of one is replaced by the matrix's values
  /// (with_matrix_values), and `ebh validate` says so
  std::vector<std::string> varied_keys = {};
};

/// `overrides` without those that set a key of `matrix` ("key=value" each), then `matrix`: a
/// stress matrix's own values for the keys it varies, in place of the user's --set of them.
std::vector<std::string> with_matrix_values(const std::vector<std::string>& overrides,
                                            const std::vector<std::string>& matrix);
/// The user's overrides that set one of `keys` (which with_matrix_values would replace).
std::vector<std::string> overrides_of_keys(const std::vector<std::string>& overrides, const std::vector<std::string>& keys);

/// Every validation, in the table's order.
const std::vector<Validation>& validations();
/// The validation called name, or null.
const Validation* find_validation(const std::string& name);

// ---- contact.cpp's cases, also for the tests ----
/// The hook driven 30 mm into the gap's block at `speed` m/s with `contact` (vertices | surface).
struct ContactPush {
  double speed = 0;           ///< m/s
  double fall = 0;            ///< N, the largest fall of |F| below its running maximum going down
  double penetration = 0;     ///< m, the virtual tool's deepest penetration
  double peak = 0;            ///< N
  double force_at_depth = 0;  ///< N, when the device reaches full depth
  bool clamped = false;       ///< the force reached the device's limit
  int inverted = 0;           ///< the most physical tets inverted after a step (ARAP gives way)
  double k_det = 0;           ///< Pa, the tissue's volume stiffness (0: the gap scene's, nu = 0)
};
/// The hook pushed 30 mm into the gap's block at `speed` with `contact` (vertices | surface), the
/// tissue's volume stiffness stiffness.k_det = det_ratio times the scene's k_vol (0: the scene's).
ContactPush contact_push_through(const std::string& contact, double speed, double det_ratio = 0);
/// Open forceps slid across a "flat" or "curved" surface with both contact models: the force's
/// power above 5 Hz (arbitrary units, comparable between the two) and mean |F|.
struct ContactSlide {
  std::string surface;
  double power_vertices = 0, power_surface = 0, mean_vertices = 0, mean_surface = 0;
};
ContactSlide contact_sliding(const std::string& surface);

// ---- the table's entries (one file each) ----
Validation column_validation();       ///< column.cpp: ARAP column reaction force vs E A delta / L
Validation contact_validation();      ///< contact.cpp: push-through and sliding, vertex vs surface contact
Validation coupling_validation();     ///< coupling.cpp: the two-rate loop across virtual iterations and k_s
Validation convergence_validation();  ///< convergence.cpp: jacobi/chebyshev vs the direct solve
Validation hertz_validation();        ///< hertz.cpp: sphere indentation force vs Hertz contact theory
Validation stability_validation();    ///< stability.cpp: replays on sliver meshes, stiffness, solvers, speeds

}  // namespace ebh
