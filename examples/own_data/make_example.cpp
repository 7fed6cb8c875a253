// Makes the own-data example (examples/own_data/README.md): a coarse organ mesh in cm and a
// 2 s Geomagic Touch log of a press into it, in the device's own frames.
//
//   make_own_data_example DIR     writes DIR/organ.msh and DIR/touch_press.txt
//
// organ.msh: an ellipsoid 12 x 8 x 5 cm centred at (0, 0, -8) cm (a kidney-sized lobe under the
// device's workspace origin): a 8 x 6 x 4 grid of cubes mapped onto the ball, each cube split into
// six tets along its diagonal (1152 tets), written by the project's own Gmsh writer.
//
// touch_press.txt: 19 columns a line, as OpenHaptics logs them: the column-major 4x4
// HD_CURRENT_TRANSFORM (translation in cm), the jaw (1) and two button states; one line per
// 1 ms, no times. Like a Touch's, the transform is of the stylus' gimbal and its +z points back
// toward the handle; the tip sits 4 cm from the gimbal along -z. So ebh's tool frame (origin at
// the tip, +z from handle to tip) is the device's turned 180 degrees about x and moved 4 cm along
// its -z: --unit cm --tool-transform 0,0,-4,180,0,0. The tip hovers 1.5 cm above the top of the
// organ, presses 0.8 cm into it, eases off to 0.5 cm and lifts off; the stylus leans 15
// degrees, with a small tremor. Every third line repeats the line before, as a device polled
// faster than it updates logs it.
//
// Deterministic: the same files on every machine (the tremor is a sum of sines).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "mesh/mesh_io.hpp"

namespace {

using ebh::Vec3d;
constexpr double kPi = std::numbers::pi;

const Vec3d kCentre{0, 0, -8};     // cm
const Vec3d kSemiAxes{6, 4, 2.5};  // cm

// The cube [-1, 1]^3 onto the unit ball, smoothly (each face to a sixth of the sphere).
Vec3d cube_to_ball(Vec3d p) {
  const double x2 = p.x * p.x, y2 = p.y * p.y, z2 = p.z * p.z;
  return {p.x * std::sqrt(1 - y2 / 2 - z2 / 2 + y2 * z2 / 3), p.y * std::sqrt(1 - z2 / 2 - x2 / 2 + z2 * x2 / 3),
          p.z * std::sqrt(1 - x2 / 2 - y2 / 2 + x2 * y2 / 3)};
}

ebh::TetMesh organ() {
  const int n[3] = {8, 6, 4};
  ebh::TetMesh m;
  auto index = [&](int i, int j, int k) { return (k * (n[1] + 1) + j) * (n[0] + 1) + i; };
  for (int k = 0; k <= n[2]; ++k)
    for (int j = 0; j <= n[1]; ++j)
      for (int i = 0; i <= n[0]; ++i) {
        const Vec3d b = cube_to_ball({2.0 * i / n[0] - 1, 2.0 * j / n[1] - 1, 2.0 * k / n[2] - 1});
        m.vertices.push_back(kCentre + Vec3d{b.x * kSemiAxes.x, b.y * kSemiAxes.y, b.z * kSemiAxes.z});
      }
  // Six tets per cube, one per path from corner 0 to corner 7 along the edges (a conforming split).
  const int order[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        for (const auto& o : order) {
          int c[3] = {i, j, k};
          ebh::Tet t;
          t[0] = index(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[o[s]];
            t[s + 1] = index(c[0], c[1], c[2]);
          }
          const Vec3d a = m.vertices[t[0]];
          if (dot(cross(m.vertices[t[1]] - a, m.vertices[t[2]] - a), m.vertices[t[3]] - a) < 0) std::swap(t[2], t[3]);
          m.tets.push_back(t);
          m.tet_group.push_back(1);
        }
  m.group_names[1] = "organ";
  return m;
}

// Minimum-jerk blend from a to b over [t0, t1].
Vec3d blend(Vec3d a, Vec3d b, double t0, double t1, double t) {
  const double s = std::clamp((t - t0) / (t1 - t0), 0.0, 1.0);
  return a + (s * s * s * (10 - 15 * s + 6 * s * s)) * (b - a);
}

// The tip's path (cm): hover, press 0.8 cm into the top of the organ (z = -5.5), ease off to
// 0.5 cm, lift. (A hook this much thinner than the mesh's 1 cm vertex spacing slips off the pole
// vertex when it slides: contact is vertex-based, README "Known limits".)
Vec3d tip(double t) {
  const Vec3d hover{0, 0, -4.0}, pressed{0, 0, -6.3}, eased{0, 0, -6.0}, lifted{0, 0, -4.0};
  if (t < 0.9) return blend(hover, pressed, 0.2, 0.9, t);
  if (t < 1.4) return blend(pressed, eased, 1.1, 1.4, t);
  return blend(eased, lifted, 1.5, 1.9, t);
}

// Rotation about x by `a` radians, then about y by `b` (the lean and its tremor), row-major.
using Mat3 = std::array<std::array<double, 3>, 3>;
Mat3 stylus_rotation(double a, double b) {
  const double ca = std::cos(a), sa = std::sin(a), cb = std::cos(b), sb = std::sin(b);
  const Mat3 rx{{{1, 0, 0}, {0, ca, -sa}, {0, sa, ca}}};
  const Mat3 ry{{{cb, 0, sb}, {0, 1, 0}, {-sb, 0, cb}}};
  Mat3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) r[i][j] += ry[i][k] * rx[k][j];
  return r;
}

// "0" for an exact zero (a logger's "-0.00000" is noise), else fixed decimals.
std::string fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (std::strtod(buf, nullptr) == 0) return "0";
  return s;
}

std::string touch_log() {
  std::string out =
      "# A Geomagic Touch press, as OpenHaptics logs it (examples/own_data/README.md; made by\n"
      "# examples/own_data/make_example.cpp): 16 column-major HD_CURRENT_TRANSFORM elements (cm),\n"
      "# jaw, button 0, button 1; one line per 1 ms; the stylus' +z points back toward the handle.\n";
  std::string previous;
  for (int i = 0; i <= 2000; ++i) {
    if (i % 3 == 2) {  // the device had not updated: the same line again
      out += previous;
      continue;
    }
    const double t = i * 1e-3;
    const double tremor = std::sin(2 * kPi * 9.0 * t) + 0.6 * std::sin(2 * kPi * 6.3 * t + 1.0);
    const Mat3 r = stylus_rotation((15 + 0.3 * tremor) * kPi / 180, 0.2 * std::sin(2 * kPi * 7.1 * t) * kPi / 180);
    // The gimbal: 4 cm behind the tip along the stylus' +z (toward the handle).
    const Vec3d z{r[0][2], r[1][2], r[2][2]};
    const Vec3d p = tip(t) + 4.0 * z + 0.01 * Vec3d{std::sin(2 * kPi * 8.3 * t), tremor / 1.6, 0.5 * tremor};
    std::string line;
    for (int c = 0; c < 3; ++c) {
      for (int row = 0; row < 3; ++row) line += fixed(r[row][c], 5) + " ";
      line += "0 ";
    }
    line += fixed(p.x, 4) + " " + fixed(p.y, 4) + " " + fixed(p.z, 4) + " 1 1 0 " + (t >= 0.2 && t < 1.9 ? "1" : "0");
    previous = line + "\n";
    out += previous;
  }
  return out;
}

void write(const std::filesystem::path& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
  if (!f) {
    std::fprintf(stderr, "make_own_data_example: %s: cannot write\n", path.c_str());
    std::exit(1);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_own_data_example DIR  (writes DIR/organ.msh and DIR/touch_press.txt)\n");
    return 1;
  }
  const std::filesystem::path dir = argv[1];
  write(dir / "organ.msh", ebh::msh22_text(organ()));
  write(dir / "touch_press.txt", touch_log());
  std::printf("%s: organ.msh (1152 tets, cm), touch_press.txt (2001 lines, cm)\n", dir.c_str());
  return 0;
}
