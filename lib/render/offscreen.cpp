#include "render/offscreen.hpp"

#include "core/error.hpp"

#ifdef EBH_HAVE_OSMESA
#include <GL/gl.h>
#include <GL/osmesa.h>
#endif

#include <cstdint>
#include <cstdlib>
#include <string>

namespace ebh {

bool have_osmesa() {
#ifdef EBH_HAVE_OSMESA
  return true;
#else
  return false;
#endif
}

#ifdef EBH_HAVE_OSMESA

struct OffscreenRenderer::Impl {
  int width = 0, height = 0, ss = 1;
  OSMesaContext ctx = nullptr;
  std::vector<GLubyte> buffer;  // RGBA, row 0 at the bottom (OSMesa's default)
  // The occlusion query (GL 1.5) that counts the tissue's fragments, from OSMesa by name (gl.h
  // declares GL 1.3 only); null where the context has none.
  PFNGLGENQUERIESPROC gen_queries = nullptr;
  PFNGLDELETEQUERIESPROC delete_queries = nullptr;
  PFNGLBEGINQUERYPROC begin_query = nullptr;
  PFNGLENDQUERYPROC end_query = nullptr;
  PFNGLGETQUERYOBJECTUIVPROC query_result = nullptr;
  GLuint query = 0;
  bool tissue_drawn = true;
  std::string renderer;  // GL_RENDERER
};

namespace {

/// Throws InputError when GALLIUM_DRIVER (the environment's choice of Mesa's software renderer)
/// names one OSMesa cannot run here: Mesa then crashes creating the context (a segmentation fault,
/// seen with a misspelt name, "swr", which Mesa 22 no longer builds, and "zink" without Vulkan)
/// instead of failing. llvmpipe and softpipe are OSMesa's own; unset or empty is its default.
void check_gallium_driver() {
  const char* driver = std::getenv("GALLIUM_DRIVER");
  if (driver == nullptr || *driver == '\0') return;
  const std::string name = driver;
  if (name == "llvmpipe" || name == "softpipe") return;
  throw InputError("GALLIUM_DRIVER '" + escape_unprintable(name) +
                   "': not a renderer OSMesa runs here (llvmpipe or softpipe; unset it for Mesa's default)");
}

}  // namespace

OffscreenRenderer::OffscreenRenderer(int width, int height, int supersample) : impl_(std::make_unique<Impl>()) {
  check_gallium_driver();
  Impl& m = *impl_;
  m.width = width;
  m.height = height;
  m.ss = supersample;
  const int W = width * supersample, H = height * supersample;
  m.buffer.resize(static_cast<std::size_t>(W) * H * 4);
  m.ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr);
  if (!m.ctx) throw InputError("OSMesa could not create a rendering context");
  if (!OSMesaMakeCurrent(m.ctx, m.buffer.data(), GL_UNSIGNED_BYTE, W, H)) {
    OSMesaDestroyContext(m.ctx);
    throw InputError("OSMesa could not make a " + std::to_string(W) + "x" + std::to_string(H) + " buffer current");
  }
  m.gen_queries = reinterpret_cast<PFNGLGENQUERIESPROC>(OSMesaGetProcAddress("glGenQueries"));
  m.delete_queries = reinterpret_cast<PFNGLDELETEQUERIESPROC>(OSMesaGetProcAddress("glDeleteQueries"));
  m.begin_query = reinterpret_cast<PFNGLBEGINQUERYPROC>(OSMesaGetProcAddress("glBeginQuery"));
  m.end_query = reinterpret_cast<PFNGLENDQUERYPROC>(OSMesaGetProcAddress("glEndQuery"));
  m.query_result = reinterpret_cast<PFNGLGETQUERYOBJECTUIVPROC>(OSMesaGetProcAddress("glGetQueryObjectuiv"));
  if (m.gen_queries && m.delete_queries && m.begin_query && m.end_query && m.query_result) m.gen_queries(1, &m.query);
  if (const GLubyte* name = glGetString(GL_RENDERER)) m.renderer = reinterpret_cast<const char*>(name);
}

OffscreenRenderer::~OffscreenRenderer() {
  if (!impl_ || !impl_->ctx) return;
  if (impl_->query != 0) impl_->delete_queries(1, &impl_->query);
  OSMesaDestroyContext(impl_->ctx);
}

bool OffscreenRenderer::tissue_drawn() const { return impl_->tissue_drawn; }
std::string OffscreenRenderer::renderer_name() const { return impl_->renderer; }

namespace {

void set_light(GLenum light, const GLfloat dir[4], GLfloat diffuse, GLfloat specular) {
  const GLfloat d[4] = {diffuse, diffuse, diffuse, 1}, s[4] = {specular, specular, specular, 1}, a[4] = {0, 0, 0, 1};
  glEnable(light);
  glLightfv(light, GL_POSITION, dir);
  glLightfv(light, GL_DIFFUSE, d);
  glLightfv(light, GL_SPECULAR, s);
  glLightfv(light, GL_AMBIENT, a);
}

void draw_soup(const TriangleSoup& s) {
  if (s.position.empty()) return;
  glVertexPointer(3, GL_FLOAT, 0, s.position.data());
  glNormalPointer(GL_FLOAT, 0, s.normal.data());
  glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(s.position.size()));
}

/// The parts of a tool that what is already drawn hides, faintly: blended, only where the depth
/// test fails, without writing depth; leaves blending off and the depth state as it was.
void draw_hidden(const TriangleSoup& s, const std::array<float, 3>& c, float alpha) {
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glDepthMask(GL_FALSE);
  glDepthFunc(GL_GREATER);
  glColor4f(c[0], c[1], c[2], alpha);
  draw_soup(s);
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);
}

}  // namespace

Image OffscreenRenderer::render(const FrameGeometry& g, const ViewCamera& camera, const RenderStyle& style) {
  Impl& m = *impl_;
  const int W = m.width * m.ss, H = m.height * m.ss;
  OSMesaMakeCurrent(m.ctx, m.buffer.data(), GL_UNSIGNED_BYTE, W, H);
  glViewport(0, 0, W, H);
  glClearColor(style.background.r / 255.0f, style.background.g / 255.0f, style.background.b / 255.0f, 1.0f);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glShadeModel(GL_SMOOTH);

  glMatrixMode(GL_PROJECTION);
  const auto P = projection_matrix(camera, static_cast<double>(m.width) / m.height);
  glLoadMatrixd(P.data());
  glMatrixMode(GL_MODELVIEW);
  glLoadIdentity();
  // Lights fixed to the camera (eye space): a key light from the upper left, a weaker fill from
  // the lower right, a soft ambient; two-sided so the inside of the tube and any back-facing
  // triangle are lit as well as the outside.
  glEnable(GL_LIGHTING);
  glLightModeli(GL_LIGHT_MODEL_TWO_SIDE, GL_TRUE);
  const GLfloat ambient[4] = {0.28f, 0.28f, 0.28f, 1};
  glLightModelfv(GL_LIGHT_MODEL_AMBIENT, ambient);
  const GLfloat key[4] = {-0.45f, 0.6f, 1.0f, 0}, fill[4] = {0.6f, -0.35f, 0.6f, 0};
  set_light(GL_LIGHT0, key, 0.72f, 0.25f);
  set_light(GL_LIGHT1, fill, 0.28f, 0.0f);
  const auto V = view_matrix(camera);
  glLoadMatrixd(V.data());
  glEnable(GL_NORMALIZE);
  glEnable(GL_COLOR_MATERIAL);
  glColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
  const GLfloat spec[4] = {0.35f, 0.35f, 0.35f, 1};
  glMaterialfv(GL_FRONT_AND_BACK, GL_SPECULAR, spec);
  glMaterialf(GL_FRONT_AND_BACK, GL_SHININESS, 28.0f);
  glEnableClientState(GL_VERTEX_ARRAY);
  glEnableClientState(GL_NORMAL_ARRAY);

  // 1. The tissue (virtual mesh), opaque, both sides.
  glDisable(GL_CULL_FACE);
  if (m.query != 0) m.begin_query(GL_SAMPLES_PASSED, m.query);
  if (g.tissue && g.triangles && !g.triangles->empty()) {
    glVertexPointer(3, GL_FLOAT, 0, g.tissue->data());
    glNormalPointer(GL_FLOAT, 0, g.tissue_normals->data());
    if (g.tissue_colors) {
      glEnableClientState(GL_COLOR_ARRAY);
      glColorPointer(3, GL_FLOAT, 0, g.tissue_colors->data());
    } else {
      glColor4f(style.tissue[0], style.tissue[1], style.tissue[2], 1.0f);
    }
    static_assert(sizeof(std::array<int, 3>) == 3 * sizeof(GLuint));
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(3 * g.triangles->size()), GL_UNSIGNED_INT, g.triangles->data());
    glDisableClientState(GL_COLOR_ARRAY);
  }
  if (m.query != 0) m.end_query(GL_SAMPLES_PASSED);

  // 2. The virtual tool, opaque grey where it is in view; where the tissue hides it (inside the
  //    tube's bore, under a fold) a faint grey ghost. Tool meshes are closed with outward faces:
  //    cull the back.
  glEnable(GL_CULL_FACE);
  glCullFace(GL_BACK);
  if (g.virtual_tool) {
    const auto& c = style.virtual_tool;
    draw_hidden(*g.virtual_tool, c, style.virtual_hidden_alpha);
    glColor4f(c[0], c[1], c[2], 1.0f);
    draw_soup(*g.virtual_tool);
  }

  // 3. The physical tool, translucent green: first its parts behind what is drawn (inside the
  //    tissue) faintly, then its nearest visible surface once (a depth-only pass, then colour
  //    where the depth matches), so overlapping colliders do not blend twice.
  if (g.physical_tool) {
    const auto& c = style.physical_tool;
    draw_hidden(*g.physical_tool, c, style.physical_hidden_alpha);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    draw_soup(*g.physical_tool);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glEnable(GL_BLEND);
    glDepthMask(GL_FALSE);
    glDepthFunc(GL_EQUAL);
    glColor4f(c[0], c[1], c[2], style.physical_alpha);
    draw_soup(*g.physical_tool);
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
    glDepthFunc(GL_LESS);
  }
  glDisableClientState(GL_VERTEX_ARRAY);
  glDisableClientState(GL_NORMAL_ARRAY);
  glFinish();
  if (m.query != 0) {
    GLuint samples = 0;
    m.query_result(m.query, GL_QUERY_RESULT, &samples);
    m.tissue_drawn = samples > 0;
  }

  // OSMesa's row 0 is the bottom row; an Image's is the top.
  Image big(W, H);
  for (int r = 0; r < H; ++r) {
    const GLubyte* src = m.buffer.data() + 4 * static_cast<std::size_t>(H - 1 - r) * W;
    std::uint8_t* dst = big.rgb.data() + 3 * static_cast<std::size_t>(r) * W;
    for (int c = 0; c < W; ++c) {
      dst[3 * c] = src[4 * c];
      dst[3 * c + 1] = src[4 * c + 1];
      dst[3 * c + 2] = src[4 * c + 2];
    }
  }
  return downsample(big, m.ss);
}

#else  // no OSMesa

struct OffscreenRenderer::Impl {};

OffscreenRenderer::OffscreenRenderer(int, int, int) { throw InputError(kNoOsmesa); }
OffscreenRenderer::~OffscreenRenderer() = default;
Image OffscreenRenderer::render(const FrameGeometry&, const ViewCamera&, const RenderStyle&) {
  throw InputError(kNoOsmesa);
}
bool OffscreenRenderer::tissue_drawn() const { return true; }
std::string OffscreenRenderer::renderer_name() const { return ""; }

#endif

}  // namespace ebh
