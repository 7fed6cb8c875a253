#include "replay_common.hpp"

#include "io/error.hpp"

namespace ebh::cli {

void check_backend(const std::string& backend) {
  if (backend == "cpu") return;
  if (backend == "cuda")
    throw InputError("--backend cuda: this build has no CUDA backend (configure with -DEBH_WITH_CUDA=ON where nvcc is installed)");
  throw InputError("--backend: expected cpu or cuda, got '" + backend + "'");
}

void render_after_replay(const std::string&, const std::string& dir) {
  throw InputError("--render " + dir + ": this build cannot render yet (ebh render is not built)");
}

}  // namespace ebh::cli
