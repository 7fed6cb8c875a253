#pragma once
// Off-screen drawing of one frame with OSMesa (software OpenGL, legacy fixed-function 1.x/2.1):
// the virtual mesh shaded with smooth normals and two-sided lighting, the virtual tool opaque
// grey, the physical tool translucent green; the parts of either tool that the tissue hides are
// drawn as faint ghosts, so a tool inside a bore or pressed into the tissue still shows. Rendered at `supersample` times the size and box-filtered down.
// Without OSMesa (EBH_HAVE_OSMESA undefined) constructing a renderer throws InputError.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "math/vec.hpp"
#include "render/camera.hpp"
#include "render/image.hpp"
#include "render/tessellate.hpp"

namespace ebh {

/// Whether this build can render (it was configured with OSMesa).
bool have_osmesa();

/// The message every renderer entry point gives in a build without OSMesa.
inline constexpr const char* kNoOsmesa = "this build has no OSMesa: install libosmesa6-dev and reconfigure";

/// Colours (linear 0..1 RGB) and opacities. The defaults are what docs/RENDER.md describes.
struct RenderStyle {
  Rgb background{246, 246, 248};
  std::array<float, 3> tissue{0.86f, 0.52f, 0.48f};          ///< flesh pink, when not coloured by a map
  std::array<float, 3> virtual_tool{0.60f, 0.61f, 0.63f};    ///< grey, opaque
  std::array<float, 3> physical_tool{0.10f, 0.78f, 0.22f};   ///< green
  float physical_alpha = 0.45f;                              ///< where nothing hides it
  float physical_hidden_alpha = 0.20f;                       ///< where tissue or the virtual tool is in front
  float virtual_hidden_alpha = 0.30f;                        ///< the virtual tool where tissue is in front
};

/// What one frame shows. Pointers stay owned by the caller; `tissue_colors` may be null (the
/// style's uniform tissue colour) or hold one colour per virtual vertex.
struct FrameGeometry {
  const std::vector<Vec3f>* tissue = nullptr;                 ///< #m positions
  const std::vector<Vec3f>* tissue_normals = nullptr;         ///< #m unit normals
  const std::vector<std::array<int, 3>>* triangles = nullptr; ///< triangles to draw
  const std::vector<std::array<float, 3>>* tissue_colors = nullptr;
  const TriangleSoup* virtual_tool = nullptr;
  const TriangleSoup* physical_tool = nullptr;
};

class OffscreenRenderer {
 public:
  /// An OSMesa context of (width * supersample) x (height * supersample) pixels.
  OffscreenRenderer(int width, int height, int supersample);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  /// Draws the frame and returns the width x height image (deterministic: the same input gives
  /// the same pixels).
  Image render(const FrameGeometry& g, const ViewCamera& camera, const RenderStyle& style);

  /// Whether the last render() drew a tissue pixel (an occlusion query around the tissue, drawn
  /// first: any of its fragments that passed the depth test). False when the camera sees none of
  /// the virtual mesh; true where the GL offers no occlusion query.
  bool tissue_drawn() const;

  /// The GL renderer that draws (GL_RENDERER: "llvmpipe (LLVM 15.0.6, 256 bits)", "softpipe"):
  /// frames are the same bytes for one renderer only (softpipe and llvmpipe differ by a few levels
  /// at edges), so each PNG names it.
  std::string renderer_name() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ebh
