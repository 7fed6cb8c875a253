// `ebh scene info NAME|PATH [--json]`: what a scene holds once loaded: mesh sizes (the paper's
// Table 1 counts), the virtual mesh, pinned vertices, bounding box, the tool's sizes next to it,
// element quality, groups, and any warnings from loading it.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include <yaml-cpp/yaml.h>


#include "command.hpp"
#include "options.hpp"
#include "core/error.hpp"
#include "core/file_names.hpp"
#include "core/number_text.hpp"
#include "io/atomic.hpp"
#include "io/json.hpp"
#include "io/paths.hpp"
#include "mesh/degrade.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "scene/scene.hpp"
#include "scene/scene_init.hpp"
#include "tool/surface_contact.hpp"
#include "tool/tool_model.hpp"
#include "scene/scene_refine.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/virtual_mesh.hpp"

namespace {

/// A scene is written as YAML: an output named otherwise is a slip (`-o other.msh` would replace a
/// mesh with a scene), refused before any work.
void require_scene_name(const std::filesystem::path& out) {
  if (ebh::has_yaml_extension(out)) return;
  const std::string ext = out.extension().string();
  throw ebh::InputError(out.string() + ": a scene is a YAML file; name it .yaml (the output would be YAML under a " +
                        (ext.empty() ? std::string("name without an extension") : "'" + ext + "' name") + ")");
}

struct SceneInfoArgs {
  std::string scene;
  bool json = false;
};

void info(const SceneInfoArgs& a) {
  const ebh::Scene scene = ebh::load_scene(ebh::resolve_scene_path(a.scene));
  // The scene's warnings and the replay's: the tool's stiffnesses', and (mode-free here) the async
  // replay's about k_s above k_svc.
  std::vector<std::string> warnings = scene.warnings;
  for (std::string& w : ebh::tool_stiffness_warnings(scene.spec)) warnings.push_back(std::move(w));
  if (std::string w = ebh::edges_outweigh_coupling_warning(scene.spec); !w.empty()) warnings.push_back(std::move(w));
  const ebh::TetMesh& m = scene.physical;
  const ebh::MeshReport report = ebh::validate_mesh(m);

  const ebh::BoundingBox bbox = ebh::bounding_box(m.vertices);
  const ebh::Vec3d lo = bbox.lo, hi = bbox.hi;
  const double bbox_diagonal = bbox.diagonal();
  const ebh::SceneSpec& spec = scene.spec;
  const ebh::ToolSpec& tool = spec.tool;
  // Contact: with `surface`, the samples' spacing (the tool's thinnest part) and the k_con the
  // samples get after the stiffness floor (tool/surface_contact.hpp).
  const bool surface = spec.contact == ebh::ContactModel::Surface;
  const double spacing = ebh::thinnest_part(ebh::build_tool(tool));
  const double k_con_surface =
      spec.stiffness.k_con * ebh::surface_stiffness_factor(spec.stiffness.k_con, tool.force_limit, spacing);
  const ebh::MeshTransform& xf = spec.mesh_transform;
  const std::vector<std::pair<std::string, double>> tool_sizes = ebh::tool_contact_sizes(tool);
  const std::vector<ebh::MeshGroup> groups = ebh::mesh_groups(m);  // by tag; tag 0 is "no group"

  // Element quality: a histogram of the mean ratio and the worst tets; the physical solver's
  // spectrum on this mesh (what decides whether and how fast its Jacobi-type methods converge).
  static const double edges[] = {0, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0000001};
  constexpr int kBins = 7;
  std::vector<long long> histogram(kBins, 0);
  std::vector<std::pair<double, int>> by_quality;
  for (int t = 0; t < static_cast<int>(m.tets.size()); ++t) {
    const ebh::Tet& c = m.tets[t];
    const double q = ebh::tet_mean_ratio(m.vertices[c[0]], m.vertices[c[1]], m.vertices[c[2]], m.vertices[c[3]]);
    by_quality.emplace_back(q, t);
    for (int b = 0; b < kBins; ++b)
      if (q < edges[b + 1]) { ++histogram[b]; break; }
  }
  const std::size_t shown = std::min<std::size_t>(5, by_quality.size());
  std::partial_sort(by_quality.begin(), by_quality.begin() + shown, by_quality.end());
  auto centroid = [&](int t) {
    ebh::Vec3d c{};
    for (int v : m.tets[t]) c += 0.25 * m.vertices[v];
    return c;
  };
  const ebh::VirtualModel vm = ebh::build_virtual_model(scene);
  ebh::check_virtual_mesh_placement(scene, vm, warnings);  // as the replay would
  ebh::PhysicalModelOptions options = ebh::physical_model_options(scene.spec);
  options.factorize = false;
  options.diagonal = ebh::SolverSpec::Diagonal::Plain;
  const ebh::PhysicalModel plain = ebh::build_physical_model(scene, &vm, options);
  std::optional<ebh::PhysicalModel> bounded;  // the scene's diagonal, when it is not the plain one
  if (scene.spec.solver.diagonal != ebh::SolverSpec::Diagonal::Plain) {
    options.diagonal = scene.spec.solver.diagonal;
    bounded = ebh::build_physical_model(scene, &vm, options);
  }
  const ebh::PhysicalModel& model = bounded ? *bounded : plain;
  const ebh::PhysicalStepParams params = ebh::physical_params(scene.spec.solver, model);
  const double gamma = params.relaxation;
  const double rate = model.spectrum.jacobi_rate(gamma);
  const double tenfold = rate < 1 ? std::log(0.1) / std::log(rate) : INFINITY;
  const double float32_floor = ebh::float32_residual_floor(model);
  if (std::string w = ebh::float32_placement_warning(scene.spec, model, float32_floor); !w.empty())
    warnings.push_back(std::move(w));  // as a replay on the CUDA backend says it
  const bool diverges = gamma * plain.spectrum.lambda_max >= 2;
  const char* diagonal = scene.spec.solver.diagonal == ebh::SolverSpec::Diagonal::Plain ? "plain" : "bounded";

  const long long tets = static_cast<long long>(m.tets.size());
  const long long boundary = report.boundary_faces;
  const long long interior = (4 * tets - boundary) / 2;  // Table 1 "triangles"
  const std::string virtual_source = scene.spec.virtual_mesh ? scene.spec.virtual_mesh->string() : "boundary";

  if (a.json) {
    ebh::Json j = ebh::Json::object();
    j.set("name", scene.spec.name);
    j.set("file", scene.spec.file.string());
    j.set("unit", scene.spec.unit_name);
    j.set("physical_mesh", scene.spec.physical_mesh.string());
    j.set("mesh_unit", spec.mesh_unit_name);
    ebh::Json t = ebh::Json::object();
    t.set("scale", xf.scale);
    t.set("rotvec_deg", ebh::Json::array_of(std::vector<double>{xf.rotvec_deg.x, xf.rotvec_deg.y, xf.rotvec_deg.z}));
    t.set("translate_m", ebh::Json::array_of(std::vector<double>{xf.translate.x, xf.translate.y, xf.translate.z}));
    j.set("transform", std::move(t));
    j.set("vertices", static_cast<long long>(m.vertices.size()));
    j.set("tets", tets);
    j.set("boundary_triangles", boundary);
    j.set("interior_faces", interior);
    ebh::Json v = ebh::Json::object();
    v.set("source", virtual_source);
    v.set("vertices", static_cast<long long>(scene.virtual_surface.vertices.size()));
    v.set("triangles", static_cast<long long>(scene.virtual_surface.triangles.size()));
    v.set("refine", scene.spec.virtual_refine);
    j.set("virtual", std::move(v));
    j.set("pinned_vertices", static_cast<long long>(scene.pinned.size()));
    ebh::Json box = ebh::Json::object();
    box.set("min", ebh::Json::array_of(std::vector<double>{lo.x, lo.y, lo.z}));
    box.set("max", ebh::Json::array_of(std::vector<double>{hi.x, hi.y, hi.z}));
    box.set("diagonal", bbox_diagonal);
    j.set("bbox_m", std::move(box));
    ebh::Json tj = ebh::Json::object();
    tj.set("kind", tool.kind == ebh::ToolSpec::Kind::Hook ? "hook" : "forceps");
    tj.set("unit", tool.unit_name);
    tj.set("shaft_length_m", tool.shaft_length);
    ebh::Json sizes = ebh::Json::object(), ratios = ebh::Json::object();
    for (const auto& [key, size] : tool_sizes) {
      sizes.set(key, size);
      ratios.set(key, size / bbox_diagonal);
    }
    tj.set("sizes_m", std::move(sizes));
    tj.set("size_over_diagonal", std::move(ratios));
    j.set("tool", std::move(tj));
    ebh::Json cj = ebh::Json::object();
    cj.set("model", surface ? "surface" : "vertices");
    if (surface) {
      cj.set("sample_spacing_m", spacing);
      cj.set("k_con_per_sample", k_con_surface);
    }
    j.set("contact", std::move(cj));
    ebh::Json q = ebh::Json::object();
    q.set("measure", "mean_ratio");
    q.set("worst", report.quality_worst);
    q.set("mean", report.quality_mean);
    q.set("worst_tet", report.worst_tet);
    ebh::Json h = ebh::Json::array();
    for (int b = 0; b < kBins; ++b) {
      ebh::Json e = ebh::Json::object();
      e.set("from", edges[b]);
      e.set("to", std::min(edges[b + 1], 1.0));
      e.set("tets", histogram[b]);
      h.push(std::move(e));
    }
    q.set("histogram", std::move(h));
    ebh::Json worst = ebh::Json::array();
    for (std::size_t i = 0; i < shown; ++i) {
      ebh::Json e = ebh::Json::object();
      const ebh::Vec3d c = centroid(by_quality[i].second);
      e.set("tet", by_quality[i].second);
      e.set("quality", by_quality[i].first);
      e.set("centroid_m", ebh::Json::array_of(std::vector<double>{c.x, c.y, c.z}));
      worst.push(std::move(e));
    }
    q.set("worst_tets", std::move(worst));
    j.set("quality", std::move(q));
    ebh::Json sv = ebh::Json::object();
    sv.set("diagonal", diagonal);
    sv.set("relaxation", gamma);
    sv.set("lambda_max_plain", plain.spectrum.lambda_max);
    sv.set("plain_diverges", diverges);
    sv.set("theta", model.diag_theta);
    sv.set("bounded_rows", model.diag_bounded_rows);
    sv.set("lambda_min", model.spectrum.lambda_min);
    sv.set("lambda_max", model.spectrum.lambda_max);
    sv.set("jacobi_rate", rate);
    sv.set("iterations_per_tenfold", tenfold);
    sv.set("chebyshev_rho", params.chebyshev_rho);
    sv.set("chebyshev_rho_auto", scene.spec.solver.chebyshev_rho_auto);
    sv.set("physical_iterations", params.iterations);
    sv.set("physical_tolerance", params.adaptive() ? params.tolerance : 0.0);
    sv.set("physical_max_iterations", params.adaptive() ? params.max_iterations : params.iterations);
    sv.set("float32_floor", float32_floor);
    j.set("solver", std::move(sv));
    ebh::Json g = ebh::Json::array();
    for (const ebh::MeshGroup& c : groups) {
      ebh::Json e = ebh::Json::object();
      e.set("tag", c.file_tag);  // the number in the mesh file
      e.set("name", c.name);
      e.set("tets", c.tets);
      e.set("triangles", c.triangles);
      g.push(std::move(e));
    }
    j.set("groups", std::move(g));
    j.set("warnings", ebh::Json::array_of(warnings));
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }

  for (const auto& w : warnings) std::fprintf(stderr, "ebh: warning: %s\n", ebh::escape_unprintable(w).c_str());
  std::printf("scene            %s (%s)\n", ebh::escape_unprintable(scene.spec.name).c_str(),
              ebh::escape_unprintable(scene.spec.file.string()).c_str());
  std::printf("unit             %s (pinned regions, camera; lengths below in metres unless a unit is named)\n",
              scene.spec.unit_name.c_str());
  std::printf("physical mesh    %s\n", scene.spec.physical_mesh.string().c_str());
  const char* mu = spec.mesh_unit_name.c_str();
  if (xf.identity()) {
    std::printf("  unit           %s, no transform\n", mu);
  } else {
    const ebh::Vec3d t = xf.translate / spec.mesh_unit;
    std::printf("  unit           %s, transform: scale %g, rotvec [%g, %g, %g] deg, translate [%g, %g, %g] %s\n", mu, xf.scale,
                xf.rotvec_deg.x, xf.rotvec_deg.y, xf.rotvec_deg.z, t.x, t.y, t.z, mu);
  }
  std::printf("  vertices       %zu\n", m.vertices.size());
  std::printf("  tets           %lld\n", tets);
  std::printf("  boundary tris  %lld\n", boundary);
  std::printf("  interior faces %lld (Table 1 \"triangles\")\n", interior);
  std::printf("virtual mesh     %s%s\n", virtual_source.c_str(), scene.spec.virtual_refine ? " (refined x4 at run time)" : "");
  std::printf("  vertices       %zu\n", scene.virtual_surface.vertices.size());
  std::printf("  triangles      %zu\n", scene.virtual_surface.triangles.size());
  std::printf("pinned vertices  %zu\n", scene.pinned.size());
  if (!spec.stiffness_regions.empty()) {
    // each region's tets that keep its k_vol (a later region may take some), by stiffness.regions' order
    std::printf("stiffness        k_vol %g Pa, with %zu region%s:\n", spec.stiffness.k_vol, spec.stiffness_regions.size(),
                spec.stiffness_regions.size() == 1 ? "" : "s");
    for (std::size_t i = 0; i < spec.stiffness_regions.size(); ++i) {
      const ebh::StiffnessRegion& r = spec.stiffness_regions[i];
      const std::vector<int> held = ebh::region_tets(scene.physical, r.region);
      long long kept = 0;
      for (int t : held) kept += scene.tet_k_vol[static_cast<std::size_t>(t)] == r.k_vol;
      std::printf("  [%zu] %-9s k_vol %g Pa: %zu tets (%lld keep it)\n", i, ebh::region_name(r.region.kind).c_str(), r.k_vol,
                  held.size(), kept);
    }
  }
  std::printf("bounding box     [%.6g, %.6g, %.6g] .. [%.6g, %.6g, %.6g] m (size %.6g x %.6g x %.6g)\n", lo.x, lo.y, lo.z,
              hi.x, hi.y, hi.z, hi.x - lo.x, hi.y - lo.y, hi.z - lo.z);
  {
    const double u = spec.unit;
    const ebh::Vec3d l = lo / u, h = hi / u, d = (hi - lo) / u;
    std::printf("  in %-11s [%.6g, %.6g, %.6g] .. [%.6g, %.6g, %.6g] (size %.6g x %.6g x %.6g, diagonal %.6g)\n",
                spec.unit_name.c_str(), l.x, l.y, l.z, h.x, h.y, h.z, d.x, d.y, d.z, bbox_diagonal / u);
  }
  {
    const double u = tool.unit;
    const char* tu = tool.unit_name.c_str();
    const bool hook = tool.kind == ebh::ToolSpec::Kind::Hook;
    std::printf("tool             %s, sizes in %s (tool.unit); its pose comes from the recording\n", hook ? "hook" : "forceps", tu);
    std::printf("  shaft          radius %g, length %g %s\n", tool.shaft_radius / u, tool.shaft_length / u, tu);
    if (hook) {
      std::printf("  hook tip       length %g, radius %g %s\n", tool.hook.tip_length / u, tool.hook.tip_radius / u, tu);
    } else {
      const ebh::ForcepsSpec& f = tool.forceps;
      std::printf("  jaws           length %g, width %g, thickness %g %s (soft margin %g), open %g deg\n", f.jaw_length / u,
                  f.jaw_width / u, f.jaw_thickness / u, tu, f.soft_margin / u, f.jaw_max_angle_deg);
    }
    std::printf("  / mesh diagonal");
    for (std::size_t i = 0; i < tool_sizes.size(); ++i)
      std::printf("%s %s %.3g", i ? "," : "", tool_sizes[i].first.c_str(), tool_sizes[i].second / bbox_diagonal);
    std::printf(" (plausible: %g .. %g)\n", ebh::kToolSizeMinRatio, ebh::kToolSizeMaxRatio);
  }
  if (surface)
    std::printf("contact          surface: samples every %g %s (the tool's thinnest part), E_con stiffness %g N/m per sample of full weight%s\n",
                spacing / tool.unit, tool.unit_name.c_str(), k_con_surface,
                k_con_surface > spec.stiffness.k_con ? " (raised from the scene's by the floor F_limit / (1.5 spacing))" : "");
  else
    std::printf("contact          vertices (E_con on the virtual mesh's vertices, the paper's)\n");
  std::printf("quality          mean ratio: worst %.4f (tet %d), mean %.4f\n", report.quality_worst, report.worst_tet,
              report.quality_mean);
  std::printf("  histogram     ");
  for (int b = 0; b < kBins; ++b) std::printf(" [%.2g, %.2g) %lld", edges[b], std::min(edges[b + 1], 1.0), histogram[b]);
  std::printf("\n");
  for (std::size_t i = 0; i < shown; ++i) {
    const ebh::Vec3d c = centroid(by_quality[i].second);
    std::printf("  worst tet      %d: %.4f at [%.6g, %.6g, %.6g] m\n", by_quality[i].second, by_quality[i].first, c.x, c.y, c.z);
  }
  if (model.num_free == 0) {
    std::printf("physical solver  nothing to solve: every vertex is pinned (the physical mesh does not move)\n");
  } else {
    std::printf("physical solver  %s diagonal, relaxation %.2g: lambda_max(D^-1 A) %.4f (plain diagonal %.4f%s)\n", diagonal,
                gamma, model.spectrum.lambda_max, plain.spectrum.lambda_max, diverges ? ": diverges" : "");
    if (model.diag_theta > 0)
      std::printf("  bounded        theta %.4f raised %d of %d rows\n", model.diag_theta, model.diag_bounded_rows, model.num_free);
    std::printf("  convergence    relaxed Jacobi error x%.4f per iteration (lambda_min %.3g): %.0f iterations per tenfold\n",
                rate, model.spectrum.lambda_min, tenfold);
    if (params.method == ebh::SolverSpec::Method::Chebyshev)
      std::printf("  chebyshev      rho %.4f (%s)\n", params.chebyshev_rho,
                  scene.spec.solver.chebyshev_rho_auto ? "auto: the rate above" : "solver.chebyshev_rho");
    if (params.adaptive())
      std::printf("  iterations     %d, then on while the step leaves more than %g mesh weights unbalanced, at most %d\n",
                  params.iterations, params.tolerance, params.max_iterations);
    else
      std::printf("  iterations     %d\n", params.iterations);
    std::printf("  float32 floor  %.2g mesh weights at rest (--backend cuda's steps go no lower)\n", float32_floor);
  }
  std::printf("groups\n");
  for (const ebh::MeshGroup& c : groups)  // each by its number in the mesh file
    std::printf("  %-14s tag %-4d %8lld tets %8lld triangles\n",
                c.name.empty() ? "(unnamed)" : ebh::escape_unprintable(c.name).c_str(), c.file_tag,
                c.tets, c.triangles);
}

struct SceneDegradeArgs {
  std::string scene;
  double quality = 0.05;
  int tets = 24;
  std::uint64_t seed = 1;
  std::string out_dir;
};

/// `ebh scene degrade`: the scene with interior vertices of its physical mesh moved until the worst
/// tet has the given mean ratio (mesh/degrade.hpp), as DIR/NAME_qQ.msh and DIR/NAME_qQ.yaml (or,
/// -o OUT.yaml, as OUT.yaml and OUT.msh beside it, as `ebh scene refine` writes), for
/// stress-testing the solver on meshes like a segmentation pipeline's.
void degrade(const SceneDegradeArgs& a) {
  if (!(a.quality > 0 && a.quality < 1)) throw ebh::InputError("--quality: expected a mean ratio in (0, 1)");
  if (a.tets < 1) throw ebh::InputError("--tets: expected at least 1");
  const std::filesystem::path file = ebh::resolve_scene_path(a.scene);
  ebh::Scene scene = ebh::load_scene(file);
  ebh::DegradeOptions o;
  o.target_quality = a.quality;
  o.tets = a.tets;
  o.seed = a.seed;
  // The outputs, refused before any work where they would overwrite an input.
  char tag[32];
  std::snprintf(tag, sizeof tag, "_q%g", a.quality);
  const std::filesystem::path out(a.out_dir);
  const bool scene_file = ebh::has_yaml_extension(out);  // -o OUT.yaml, else a folder
  // In a folder the outputs are named after the scene's `name`, text of the scene file: one that
  // is no file name ('../../x', an absolute path) would write outside the folder.
  if (const std::string why = ebh::file_name_problem(scene.spec.name); !scene_file && !why.empty())
    throw ebh::InputError(file.string() + ": key 'name': '" + scene.spec.name + "' " + why +
                          ": with -o DIR the outputs are named after it (DIR/NAME" + tag + ".yaml); rename the scene, or "
                          "give -o OUT.yaml");
  const std::filesystem::path dir = a.out_dir.empty() ? std::filesystem::path(".") : out;
  const std::string scene_out = scene_file ? out.string() : (dir / (scene.spec.name + tag + ".yaml")).string();
  std::vector<ebh::RoleFile> inputs = {{file.string(), "the scene"}, {scene.spec.physical_mesh.string(), "the physical mesh"}};
  if (scene.spec.virtual_mesh) inputs.push_back({scene.spec.virtual_mesh->string(), "the virtual mesh"});
  // The scene first: the mesh goes beside the file it really is (a link's target), which the scene
  // names it from.
  ebh::check_outputs({{scene_out, "the degraded scene"}}, inputs);
  const std::string mesh_out = ebh::companion_output(scene_out, ".msh");
  ebh::check_outputs({{scene_out, "the degraded scene"}, {mesh_out, "the degraded mesh"}}, inputs);
  // A mesh already as bad as asked: the tets would not move, and the "degraded" copy would be the
  // mesh itself.
  if (const ebh::MeshReport before = ebh::validate_mesh(scene.physical); before.quality_worst <= a.quality) {
    char why[160];
    std::snprintf(why, sizeof why, ": the physical mesh's worst mean ratio is already %.4g (%s), at or below --quality %g",
                  before.quality_worst, before.worst_tet_name.c_str(), a.quality);
    throw ebh::InputError(file.string() + why + ": nothing to degrade (give a quality below it)");
  }
  const ebh::DegradeReport r = ebh::degrade_physical_mesh(scene, o);
  if (r.worst_quality > a.quality * (1 + 1e-6))
    throw ebh::InputError(file.string() + ": no interior tet of the physical mesh could be degraded to mean ratio " +
                          ebh::shown_number(a.quality));
  if (const int done = r.caps + r.slivers + r.needles; done < a.tets)
    std::fprintf(stderr,
                 "ebh: warning: %s: degraded %d of the %d tets asked for (--tets): the mesh has no more interior "
                 "vertices away from those moved (a degraded tet's neighbours are left alone)\n",
                 file.string().c_str(), done, a.tets);


  // The scene file as it is, pointing at the new mesh beside it (by its name, relative to the
  // folder the scene is written in, a link's target's: the two move together) and at every other
  // file by its absolute path.
  YAML::Node root = YAML::LoadFile(file.string());
  root["name"] = scene.spec.name + tag;  // as refine's NAME_lN: a recording of NAME replays on it without a word
  root["mesh"]["physical"] = std::filesystem::path(mesh_out).filename().string();
  if (scene.spec.virtual_mesh) root["mesh"]["virtual"] = std::filesystem::absolute(*scene.spec.virtual_mesh).string();
  YAML::Emitter yaml;
  yaml << root;
  char header[512];
  std::snprintf(header, sizeof header,
                "# %s with its physical mesh degraded by `ebh scene degrade %s --quality %g --tets %d --seed %llu`:\n"
                "# worst mean ratio %.4g (tet %d); %d caps, %d slivers, %d needles.\n",
                ebh::escape_unprintable(scene.spec.name).c_str(), ebh::escape_unprintable(a.scene).c_str(), a.quality,
                a.tets, static_cast<unsigned long long>(a.seed),
                r.worst_quality, r.worst_tet, r.caps, r.slivers, r.needles);
  // Back into the mesh file's coordinates and unit, so the scene's mesh.unit and mesh.transform
  // place it as they placed the original.
  ebh::TetMesh file_mesh = scene.physical;
  const ebh::MeshTransform& xf = scene.spec.mesh_transform;
  if (!xf.identity())
    for (ebh::Vec3d& p : file_mesh.vertices) p = xf.inverse(p);
  // The mesh and the scene that names it belong together: both or neither.
  const std::string mesh_text = ebh::msh22_text(file_mesh, 1.0 / scene.spec.mesh_unit);
  const std::string scene_text = std::string(header) + yaml.c_str() + "\n";
  ebh::write_files_atomically({{mesh_out, mesh_text}, {scene_out, scene_text}});
  std::printf("%s: %s with worst mean ratio %.4g (tet %d; %d caps, %d slivers, %d needles), mesh %s\n", scene_out.c_str(),
              ebh::escape_unprintable(scene.spec.name).c_str(), r.worst_quality, r.worst_tet, r.caps, r.slivers, r.needles,
              mesh_out.c_str());
}

struct SceneRefineArgs {
  std::string scene, out;
  int level = 1;
  std::int64_t max_tets = ebh::kMaxRefinedTets;
  bool keep_virtual = false;
};

/// `ebh scene refine`: the scene with its physical mesh split uniformly, every tet into 8 a level
/// (scene/scene_refine.hpp), as OUT.yaml with OUT.msh (and OUT.obj for a virtual mesh of its own
/// file or a kept one) beside it.
void refine(const SceneRefineArgs& a) {
  require_scene_name(a.out);
  const std::filesystem::path file = ebh::resolve_scene_path(a.scene);
  const ebh::SceneSpec spec = ebh::load_scene_spec(file);
  std::vector<ebh::RoleFile> inputs = {{file.string(), "the scene"}, {spec.physical_mesh.string(), "the physical mesh"}};
  if (spec.virtual_mesh) inputs.push_back({spec.virtual_mesh->string(), "the virtual mesh"});
  // The scene first: its meshes go beside the file it really is (a link's target; refine_scene
  // names them alike), which the scene names them from.
  ebh::check_outputs({{a.out, "the refined scene"}}, inputs);
  const std::string mesh_out = ebh::companion_output(a.out, ".msh");
  const std::string obj_out = ebh::companion_output(a.out, ".obj");
  std::vector<ebh::RoleFile> outputs = {{a.out, "the refined scene"}, {mesh_out, "the refined mesh"}};
  if (spec.virtual_mesh || a.keep_virtual)
    outputs.push_back({obj_out, a.keep_virtual ? "the kept virtual mesh" : "the refined virtual mesh"});
  ebh::check_outputs(outputs, inputs);
  // Refined for the file written (a link's target), whose folder the scene names its meshes from.
  const ebh::RefinedScene r =
      ebh::refine_scene(file, a.level, ebh::output_target(a.out), a.max_tets, a.scene, a.keep_virtual);
  std::vector<std::pair<std::string, std::string_view>> files = {{r.mesh_file.string(), r.mesh_text}};
  if (!r.virtual_file.empty()) files.push_back({r.virtual_file.string(), r.virtual_text});
  files.push_back({a.out, r.scene_yaml});
  ebh::write_files_atomically(files);
  std::printf("%s: %s, %lld tets and %lld vertices (from %lld and %lld), mesh %s%s%s\n", a.out.c_str(), r.name.c_str(),
              static_cast<long long>(r.after.tets), static_cast<long long>(r.after.vertices),
              static_cast<long long>(r.before.tets), static_cast<long long>(r.before.vertices),
              r.mesh_file.string().c_str(), r.virtual_file.empty() ? "" : ", virtual mesh ",
              r.virtual_file.string().c_str());
}

/// `ebh scene init`: a complete, commented scene for the user's own mesh (scene/scene_init.hpp),
/// checked by loading it before it is written.
void init(const ebh::SceneInitOptions& o) {
  const std::string mesh = o.mesh.string(), out = o.out.string();
  if (out.empty()) throw ebh::InputError("-o: output file name is empty");
  ebh::check_input_file(mesh);
  ebh::check_outputs({{out, "the scene"}}, {{mesh, "the mesh"}});
  require_scene_name(o.out);
  ebh::SceneInitOptions at = o;
  at.written = ebh::output_target(out);  // a link's target: its mesh path is relative to the target's folder
  const ebh::SceneInit made = ebh::make_scene(at);
  for (const auto& w : made.scene.warnings) std::fprintf(stderr, "ebh: warning: %s\n", ebh::escape_unprintable(w).c_str());
  ebh::write_file_atomically(out, made.yaml);
  const ebh::TetMesh& m = made.scene.physical;
  std::printf("%s: scene for %s (%zu vertices, %zu tets, in %s), %s, %s\n", out.c_str(), mesh.c_str(), m.vertices.size(),
              m.tets.size(), o.unit.c_str(), o.tissue.c_str(), o.tool.c_str());
  std::printf("  %s\n", made.pin_note.c_str());
  if (!made.speck_note.empty()) std::printf("  %s\n", made.speck_note.c_str());
  if (!made.resolution_note.empty()) std::printf("  %s\n", made.resolution_note.c_str());
  std::printf("  check it: ebh scene info %s\n", ebh::shell_word(out).c_str());
}

void setup(CLI::App& root) {
  CLI::App* scene = root.add_subcommand("scene", "Inspect scenes (scenarios/NAME.yaml)");
  scene->require_subcommand(1);
  auto args = std::make_shared<SceneInfoArgs>();
  CLI::App* c = scene->add_subcommand("info", "Load a scene and print its mesh sizes, pinned vertices, bounding box, quality and the physical solver's convergence on it");
  c->add_option("scene", args->scene, "scene name (scenarios/NAME.yaml) or path to a scene file")->required();
  c->add_flag("--json", args->json, "print JSON instead of text");
  c->callback([args] { info(*args); });

  auto dargs = std::make_shared<SceneDegradeArgs>();
  CLI::App* d = scene->add_subcommand(
      "degrade", "Write the scene with bad tets in its physical mesh (caps, slivers, needles down to --quality) for stress tests");
  d->add_option("scene", dargs->scene, "scene name (scenarios/NAME.yaml) or path to a scene file")->required();
  d->add_option("--quality", dargs->quality, "the worst tet's mean ratio afterwards, in (0, 1) (default 0.05)");
  d->add_option("--tets", dargs->tets, "how many interior tets to degrade (default 24)");
  d->add_option("--seed", dargs->seed, "which tets (default 1; the same seed gives the same mesh)")
      ->check(ebh::cli::seed_number());
  d->add_option("-o,--out", dargs->out_dir,
                "folder for NAME_qQ.msh and NAME_qQ.yaml (default: the working directory), or the scene file to write "
                "(OUT.yaml; the mesh goes to OUT.msh beside it)");
  d->callback([dargs] { degrade(*dargs); });

  auto rargs = std::make_shared<SceneRefineArgs>();
  CLI::App* r = scene->add_subcommand(
      "refine", "Write the scene with its physical mesh refined uniformly (every tet into 8 per level) for size studies");
  r->add_option("scene", rargs->scene, "scene name (scenarios/NAME.yaml) or path to a scene file")->required();
  r->add_option("--level", rargs->level, "how many times to split every tet into 8 (1 or more; default 1)")
      ->check(ebh::cli::whole_number(1, std::numeric_limits<int>::max()));
  r->add_option("-o,--out", rargs->out, "the scene file to write (OUT.yaml; the mesh goes to OUT.msh beside it)")->required();
  r->add_option("--max-tets", rargs->max_tets,
                "refuse a refined mesh of more tets than this (default " + std::to_string(ebh::kMaxRefinedTets) + ")")
      ->check(ebh::cli::whole_number(1, std::numeric_limits<std::int64_t>::max()));
  r->add_flag("--keep-virtual", rargs->keep_virtual,
              "keep the virtual mesh at the scene's resolution (written to OUT.obj): only the physical mesh is refined");
  r->callback([rargs] { refine(*rargs); });

  auto iargs = std::make_shared<ebh::SceneInitOptions>();
  CLI::App* i = scene->add_subcommand(
      "init", "Write a complete, commented scene for your own mesh (tool in mm, tissue presets, pinned regions)");
  i->add_option("mesh", iargs->mesh, "the physical mesh of tets (Gmsh .msh 2.2 or 4.1, VTK legacy .vtk, Medit .mesh, or TetGen .node/.ele)")->required();
  i->add_option("-o,--out", iargs->out, "the scene file to write")->required();
  i->add_option("--unit", iargs->unit, "the mesh file's unit, also the scene's for --pin and the camera: m, cm, mm, in (default mm)");
  i->add_option("--pin", iargs->pins,
                "a pinned region, repeatable: sphere:x,y,z,r | box:x0,y0,z0,x1,y1,z1 | group:NAME (default: the vertices "
                "within 5% of the mesh's height of its lowest point, -z, widened until at least 3)")
      ->allow_extra_args(false);
  i->add_option("--tissue", iargs->tissue, "stiffness and density preset: liver, gallbladder, uterus, generic (default generic)");
  i->add_option("--tool", iargs->tool, "hook or forceps (default hook)");
  i->callback([iargs] { init(*iargs); });
}

}  // namespace

EBH_COMMAND(setup);
