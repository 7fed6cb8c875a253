#include "replay_common.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "core/error.hpp"
#if EBH_HAVE_CUDA
#include "solver/device_cuda.hpp"
#endif
#include "io/atomic.hpp"
#include "io/h5.hpp"
#include "render/render_replay.hpp"
#include "render/xdmf.hpp"

namespace ebh::cli {

void check_backend(const std::string& backend) {
  if (backend == "cpu") return;
  if (backend == "cuda") {
#if EBH_HAVE_CUDA
    std::string why;
    if (!cuda_device_available(&why)) throw InputError("--backend cuda: " + why + " on this machine");
    return;
#else
    throw InputError("--backend cuda: this build has no CUDA backend (configure with -DEBH_WITH_CUDA=ON where nvcc is installed)");
#endif
  }
  throw InputError("--backend: expected cpu or cuda, got '" + backend + "'");
}

std::unique_ptr<OffscreenRenderer> start_render_after_replay(const std::string& dir) {
  check_frames_folder(dir);
  try {
    return start_renderer(RenderOptions{});
  } catch (const InputError& e) {
    if (!have_osmesa()) throw;  // kNoOsmesa, as `ebh render` says it
    throw InputError("--render " + dir + ": " + e.what());
  }
}

void render_after_replay(const std::string& finished, const std::string& out, const std::string& dir,
                         OffscreenRenderer& renderer) {
  // The frames are read from the finished output under its temporary name: messages name it OUT.
  const auto named = [&](std::string text) {
    for (std::size_t at = 0; !finished.empty() && (at = text.find(finished, at)) != std::string::npos; at += out.size())
      text.replace(at, finished.size(), out);
    return text;
  };
  RenderSummary s;
  try {
    s = render_replay(finished, dir, RenderOptions{}, &renderer);
  } catch (const InputError& e) {
    // The output has not replaced the previous one yet: a render cut short by an interrupt or a
    // failed frame (a full disk) leaves both the previous output and the previous frames.
    if (interrupted())
      throw InputError(dir + ": interrupted while rendering: nothing written (" + out + " and the frames are as they were)");
    throw InputError(named(e.what()) + " (nor is the replay's output written: " + out + " is as it was)");
  }
  for (const auto& w : s.warnings) std::fprintf(stderr, "ebh: warning: %s\n", ebh::escape_unprintable(named(w)).c_str());
}

namespace {

/// Removes `path` when it is a regular file (or a link to one): a stale index. A device, a named
/// pipe or a socket of that name is the user's, and stays.
bool remove_index(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec) && std::filesystem::remove(path, ec);
}

}  // namespace

void index_replay_frames(const std::string& replay_file) {
  bool frames = false;
  {
    const h5::File f = h5::File::open_read(replay_file);
    frames = f.has("frames/t") && f.dataset("frames/t").shape().at(0) > 0;
  }
  if (!frames) {
    // An index this file's earlier replay left (with frames) points at frames it no longer has:
    // ParaView would fail on it. Only an index that names this file's frames is removed.
    const std::string xdmf = xdmf_path_for(replay_file);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(xdmf, ec)) return;  // a named pipe's open would wait for a writer
    std::ifstream in(xdmf);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string frames_of = std::filesystem::path(replay_file).filename().string() + ":/frames/";
    if (text.find(frames_of) != std::string::npos) remove_index(xdmf);
    return;
  }
  // Written after the replay output, from it: a failure here leaves the output written and an
  // index of the previous one, if any, which no longer matches it.
  try {
    write_xdmf(replay_file);
  } catch (const InputError& e) {
    const bool stale_removed = remove_index(xdmf_path_for(replay_file));
    throw InputError(std::string(e.what()) + " (" + replay_file + " is written" +
                     (stale_removed ? "; the previous index, which no longer matched it, is removed" : "") +
                     "; `ebh render " + replay_file + " --xdmf-only` writes the index again)");
  }
}

}  // namespace ebh::cli
