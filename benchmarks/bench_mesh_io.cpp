// Mesh input speed: reading the committed scene meshes (target: a 50k-tet MSH file in < 0.2 s).
#include <benchmark/benchmark.h>

#include <string>

#include "mesh/mesh_io.hpp"

namespace {

void BM_ReadMsh(benchmark::State& state, const std::string& name) {
  const std::string path = std::string(EBH_SOURCE_DIR) + "/scenarios/" + name + ".msh";
  std::size_t tets = 0;
  for (auto _ : state) {
    const ebh::TetMesh m = ebh::read_msh(path);
    tets = m.tets.size();
    benchmark::DoNotOptimize(tets);
  }
  state.counters["tets"] = static_cast<double>(tets);
}

BENCHMARK_CAPTURE(BM_ReadMsh, tube, std::string("tube"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ReadMsh, gynaecology_msh22, std::string("gynaecology"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ReadMsh, cholecystectomy, std::string("cholecystectomy"))->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
