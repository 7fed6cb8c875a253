#pragma once
// Pieces shared by the commands that run replays (replay, and the rendering hook).
#include <memory>
#include <string>

#include "render/offscreen.hpp"
#include "schedule/replay_inputs.hpp"

namespace ebh::cli {

/// Accepts "cpu", and "cuda" when this build has the CUDA backend and a device; otherwise an
/// InputError that says how to get it.
void check_backend(const std::string& backend);

/// `ebh replay --render DIR`, before the replay: what can fail in the renderer's setup (DIR's
/// frame names, OSMesa's context) fails here, before the replay's output replaces a previous one.
std::unique_ptr<OffscreenRenderer> start_render_after_replay(const std::string& dir);

/// `ebh replay --render DIR`: renders the replay's frames like `ebh render OUT -o DIR`, with the
/// renderer start_render_after_replay made, from `finished`: the output OUT written and synced but
/// not yet renamed into place (ReplayWriter::finish), so that a render that fails leaves the previous
/// output with the previous frames. Messages name OUT.
void render_after_replay(const std::string& finished, const std::string& out, const std::string& dir,
                         OffscreenRenderer& renderer);

/// After `ebh replay` committed its output: when it holds frames, writes OUT.xdmf beside it (the
/// ParaView index of the mesh snapshots, render/xdmf.hpp); otherwise does nothing.
void index_replay_frames(const std::string& replay_file);

}  // namespace ebh::cli
