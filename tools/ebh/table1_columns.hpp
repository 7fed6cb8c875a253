#pragma once
// The paper's Table 1: each column's scenes, recordings and windows, with the paper's numbers.
// `ebh table1` measures them; `ebh bench sizes` takes a scene's window from here by default.
#include <cstring>

namespace ebh::cli {

/// One column of Table 1 with the paper's numbers beside ours.
struct Table1Column {
  const char* label;
  const char* press_scene;
  const char* press_recording;
  double press_start;
  const char* grasp_scene;
  const char* grasp_recording;
  double grasp_start;
  int paper_tets, paper_triangles;
  double paper_press_fps, paper_grasp_fps, paper_haptic_fps;
};

// Windows start just before contact (the gate uses the same ones: tests/gate/baselines.yaml).
inline constexpr Table1Column kTable1Columns[] = {
    {"cholecystectomy", "cholecystectomy_hook", "cholecystectomy_press", 0.9, "cholecystectomy", "cholecystectomy_grasp",
     0.8, 44178, 82748, 125.1, 123.3, 1003.2},
    {"gynaecology", "gynaecology_hook", "gynaecology_press", 0.9, "gynaecology", "gynaecology_grasp", 0.8, 16848, 29102,
     131.0, 132.2, 1004.1},
    {"tube", "tube", "tube_insert", 1.8, "tube_forceps", "tube_grasp", 0.8, 8068, 14588, 137.8, 140.3, 998.1},
    {"gap", "gap", "gap_insert", 2.0, "gap_forceps", "gap_grasp", 0.8, 16630, 30812, 140.0, 140.1, 1007.5},
};

/// A committed scene's Table 1 window: its recording and start (s), when `scene` is one of the
/// columns' press or grasp scenes.
struct Table1Window {
  const char* recording = nullptr;
  double start = 0;
};
inline Table1Window table1_window(const char* scene) {
  for (const Table1Column& c : kTable1Columns) {
    if (std::strcmp(c.press_scene, scene) == 0) return {c.press_recording, c.press_start};
    if (std::strcmp(c.grasp_scene, scene) == 0) return {c.grasp_recording, c.grasp_start};
  }
  return {};
}

}  // namespace ebh::cli
