# Command-line tests of mesh-size studies: `ebh scene refine`, `ebh bench sizes` and
# `ebh table1 --backend cuda` where no device can be used.
set(EBH_BIN $<TARGET_FILE:ebh>)
set(EBH_SIZES_OUT ${PROJECT_BINARY_DIR}/cli_sizes)
set(Z ${EBH_SIZES_OUT})
file(MAKE_DIRECTORY ${Z}/again ${Z}/own ${Z}/kept)
set(EXPECT_FAILURE ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)

# The tube one level finer, twice into two folders: the same bytes; it replays a window of its recording.
add_test(NAME cli.scene.refine COMMAND ${EBH_BIN} scene refine tube --level 1 -o ${Z}/tube_l1.yaml)
set_tests_properties(cli.scene.refine PROPERTIES FIXTURES_SETUP refined_tube LABELS "cli;scene" PASS_REGULAR_EXPRESSION
  "tube_l1.yaml: tube_l1, 64456 tets and 14014 vertices \\(from 8057 and 2150\\), mesh .*tube_l1.msh\n")
# The refined scene is YAML: a name of another kind is refused before any work (as by `scene init`).
add_test(NAME cli.scene.refine_to_a_text_file
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;tube;--level;1;-o;${Z}/tube_l1.txt"
    "-DEXPECT=^ebh: error: .*tube_l1.txt: a scene is a YAML file; name it .yaml \\(the output would be YAML under a '.txt' name\\)"
    -DOUTPUT=${Z}/tube_l1.txt -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene.refine_to_a_text_file PROPERTIES LABELS "cli;scene")
add_test(NAME cli.scene.refine_again COMMAND ${EBH_BIN} scene refine tube --level 1 -o ${Z}/again/tube_l1.yaml)
set_tests_properties(cli.scene.refine_again PROPERTIES FIXTURES_SETUP refined_tube LABELS "cli;scene")
add_test(NAME cli.scene.refine_is_deterministic
  COMMAND ${CMAKE_COMMAND} -E compare_files ${Z}/tube_l1.msh ${Z}/again/tube_l1.msh)
add_test(NAME cli.scene.refine_is_deterministic_yaml
  COMMAND ${CMAKE_COMMAND} -E compare_files ${Z}/tube_l1.yaml ${Z}/again/tube_l1.yaml)
# Only the physical mesh refined: the virtual mesh written as it was.
add_test(NAME cli.scene.refine_keep_virtual COMMAND ${EBH_BIN} scene refine tube --level 1 --keep-virtual -o ${Z}/kept/tube_l1.yaml)
set_tests_properties(cli.scene.refine_keep_virtual PROPERTIES LABELS "cli;scene" PASS_REGULAR_EXPRESSION
  "tube_l1.yaml: tube_l1, 64456 tets and 14014 vertices \\(from 8057 and 2150\\), mesh .*tube_l1.msh, virtual mesh .*kept/tube_l1.obj\n")
add_test(NAME cli.replay.refined_tube
  COMMAND ${EBH_BIN} replay ${Z}/tube_l1.yaml tube_insert -o ${Z}/tube_l1.h5 --start 1.8 --duration 0.2)
set_tests_properties(cli.replay.refined_tube PROPERTIES PASS_REGULAR_EXPRESSION
  "tube_l1.h5: tube_l1 \\+ tube_insert.h5, async mode, 201 ticks, 21 physical steps.*peak force [0-9.]+ N")
set_tests_properties(cli.scene.refine_is_deterministic cli.scene.refine_is_deterministic_yaml cli.replay.refined_tube
  PROPERTIES FIXTURES_REQUIRED refined_tube LABELS "cli;scene")

# Bad input: one line, exit status 1, no file left.
add_test(NAME cli.scene.refine_level_zero
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;tube;--level;0;-o;${Z}/zero.yaml"
    "-DEXPECT=^ebh: error: --level: expected a whole number in \\[1, 2147483647\\], got .0." -DOUTPUT=${Z}/zero.yaml -DSTATUS=1 -P ${EXPECT_FAILURE})
add_test(NAME cli.scene.refine_missing_scene
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;no_such_scene;-o;${Z}/missing.yaml"
    "-DEXPECT=^ebh: error: no_such_scene: no such scene" -DOUTPUT=${Z}/missing.yaml -DSTATUS=1 -P ${EXPECT_FAILURE})
file(WRITE ${Z}/afile "not a folder\n")
add_test(NAME cli.scene.refine_unwritable
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;tube;-o;${Z}/afile/tube_l1.yaml"
    "-DEXPECT=^ebh: error: .*afile/tube_l1.yaml: cannot create the output: Not a directory" -DSTATUS=1 -P ${EXPECT_FAILURE})
# A scene beside its own mesh: an output named after the mesh (or the scene) would replace it.
configure_file(${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube22.msh ${Z}/own/cube22.msh COPYONLY)
file(WRITE ${Z}/own/cube.yaml "unit: mm\nmesh: {physical: cube22.msh}\npinned:\n  - group: bottom\n")
add_test(NAME cli.scene.refine_over_its_mesh
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;${Z}/own/cube.yaml;-o;${Z}/own/cube22.yaml"
    "-DEXPECT=^ebh: error: .*cube22.msh: the output would replace the physical mesh .*cube22.msh"
    "-DKEEP=${Z}/own/cube22.msh;${Z}/own/cube.yaml" -DOUTPUT=${Z}/own/cube22.yaml -DSTATUS=1 -P ${EXPECT_FAILURE})
add_test(NAME cli.scene.refine_over_its_scene
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;${Z}/own/cube.yaml;-o;${Z}/own/cube.yaml"
    "-DEXPECT=^ebh: error: .*cube.yaml: the output would replace the scene .*cube.yaml"
    "-DKEEP=${Z}/own/cube22.msh;${Z}/own/cube.yaml" -DSTATUS=1 -P ${EXPECT_FAILURE})
# Too large: the sizes and the memory it would take, before any work.
add_test(NAME cli.scene.refine_too_large
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;cholecystectomy;--level;3;-o;${Z}/chole_l3.yaml"
    "-DEXPECT=^ebh: error: .*cholecystectomy.yaml: level 3 makes 22.5 million tets and 3.85 million vertices .*GB to write and .*GB to replay, over the limit of 8 million tets \\(--max-tets raises it\\)"
    -DOUTPUT=${Z}/chole_l3.yaml -DSTATUS=1 -P ${EXPECT_FAILURE})
# A size just over --max-tets is said exactly, not as '64.5 thousand over the limit of 64.5 thousand'.
add_test(NAME cli.scene.refine_just_over_the_limit
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;tube;--level;1;--max-tets;64455;-o;${Z}/just_over.yaml"
    "-DEXPECT=^ebh: error: .*tube.yaml: level 1 makes 64456 tets .*over the limit of 64455 tets"
    -DOUTPUT=${Z}/just_over.yaml -DSTATUS=1 -P ${EXPECT_FAILURE})
# --max-tets at its largest lifts the limit, not what a mesh can index: a count past INT64_MAX
# (5 tets x 8^22) is refused, not saturated into the limit and refined until the memory is gone.
add_test(NAME cli.scene.refine_no_limit
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;refine;${Z}/own/cube.yaml;--level;22;--max-tets;9223372036854775807;-o;${Z}/no_limit.yaml"
    "-DEXPECT=^ebh: error: .*cube.yaml: level 22 makes 3.69e\\+20 tets .*, over the 2147483647 tets or vertices a mesh can index \\(its indices are 32-bit\\)"
    -DOUTPUT=${Z}/no_limit.yaml -DSTATUS=1 -P ${EXPECT_FAILURE})
set_tests_properties(cli.scene.refine_no_limit PROPERTIES TIMEOUT 60)
set_tests_properties(cli.scene.refine_level_zero cli.scene.refine_missing_scene cli.scene.refine_unwritable
  cli.scene.refine_over_its_mesh cli.scene.refine_over_its_scene cli.scene.refine_too_large cli.scene.refine_no_limit
  PROPERTIES LABELS "cli;scene")

# ebh bench sizes, short: levels 0-1 of the tube, 0.1 s each; JSON and the plot.
add_test(NAME cli.bench.sizes
  COMMAND ${EBH_BIN} bench sizes --scene tube --levels 0-1 --seconds 0.1 --plot ${Z}/sizes.png)
set_tests_properties(cli.bench.sizes PROPERTIES LABELS "cli;bench" PASS_REGULAR_EXPRESSION
  "tube \\+ tube_insert from 1.8 s, 0.1 s, async, cpu.*\n +0 +8057 +2150 +6628 .*\n +1 +64456 +14014 +26512 .*slope against tets \\(log-log least squares; 1 = linear\\): physical step [0-9.]+, haptic tick [0-9.]+, wall per virtual s [0-9.]+, host memory [0-9.]+\n.*sizes.png: the costs against tets")
add_test(NAME cli.bench.sizes_json
  COMMAND ${EBH_BIN} bench sizes --levels 0 --seconds 0.05 --set solver.active_region=0.001 --json)
set_tests_properties(cli.bench.sizes_json PROPERTIES LABELS "cli;bench" PASS_REGULAR_EXPRESSION
  "\"backend\": \"cpu\",\n +\"overrides\": \\[\n +\"solver.active_region=0.001\"\n +\\],.*\"tets\": 8057,.*\"ticks\": 51,.*\"device_peak_bytes\": null.*\"slopes\": \\{\n +\"physical_step_median\": null")
add_test(NAME cli.bench.sizes_bad_levels
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--levels;3-1"
    "-DEXPECT=^ebh: error: --levels: expected FIRST-LAST \\(e.g. 0-3\\) or one level, levels >= 0, got '3-1'" -DSTATUS=1
    -P ${EXPECT_FAILURE})
# A level past int's range, a blank or a sign is refused, not wrapped or skipped (sscanf read
# 4294967296 as 0 and ' 1' as 1).
add_test(NAME cli.bench.sizes_levels_wrap
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--levels;0-4294967296"
    "-DEXPECT=^ebh: error: --levels: expected FIRST-LAST \\(e.g. 0-3\\) or one level, levels >= 0, got '0-4294967296'" -DSTATUS=1
    -P ${EXPECT_FAILURE})
add_test(NAME cli.bench.sizes_levels_blank
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--levels;0- 1"
    "-DEXPECT=^ebh: error: --levels: expected FIRST-LAST \\(e.g. 0-3\\) or one level, levels >= 0, got '0- 1'" -DSTATUS=1
    -P ${EXPECT_FAILURE})
add_test(NAME cli.bench.sizes_no_window
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--scene;${CMAKE_CURRENT_SOURCE_DIR}/data/scene/cube.yaml"
    "-DEXPECT=^ebh: error: --recording: missing, and scene '.*cube.yaml' has no default recording \\(.*\\); give --recording and --start, where in it"
    -DSTATUS=1 -P ${EXPECT_FAILURE})
# --start given names no recording: what is missing is --recording alone, not --start.
add_test(NAME cli.bench.sizes_no_window_start_given
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--scene;${CMAKE_CURRENT_SOURCE_DIR}/data/scene/cube.yaml;--start;2"
    "-DEXPECT=^ebh: error: --recording: missing, and scene '.*cube.yaml' has no default recording \\(.*\\); give --recording \\(--start 2 is a time into it\\)\n$"
    -DSTATUS=1 -DNO_STDOUT=1 -P ${EXPECT_FAILURE})
# A misspelt override: one line before the heading, no plot.
add_test(NAME cli.bench.sizes_bad_override
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--levels;0;--set;solver.active_regio=0.001;--plot;${Z}/bad.png"
    "-DEXPECT=^ebh: error: --set 'solver.active_regio=0.001': key 'solver.active_regio': unknown key" -DOUTPUT=${Z}/bad.png -DSTATUS=1
    -P ${EXPECT_FAILURE})
# A window past the recording's end: replay's own check and words, before the heading.
add_test(NAME cli.bench.sizes_start_past_end
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--levels;0;--start;1e9"
    "-DEXPECT=^ebh: error: --start 1000000000: the recording .*tube_insert.h5 is 10 s long; start before its end"
    -DSTATUS=1 -DNO_STDOUT=1 -P ${EXPECT_FAILURE})
# An override of a mesh file would replace the refined mesh at every size (one mesh measured at
# every level): refused before any work, a map override's leaf too.
add_test(NAME cli.bench.sizes_mesh_override
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--levels;0-1;--set;mesh={virtual: other.msh}"
    "-DEXPECT=^ebh: error: --set 'mesh={virtual: other.msh}': key 'mesh.virtual': bench sizes refines the scene's own meshes, which this would replace at every size; give a scene that names this mesh \\(--scene\\)\n$"
    -DSTATUS=1 -DNO_STDOUT=1 -P ${EXPECT_FAILURE})
# A Table 1 scene given as its file has its name's window.
add_test(NAME cli.bench.sizes_scene_file_window
  COMMAND ${EBH_BIN} bench sizes --scene ${PROJECT_SOURCE_DIR}/scenarios/tube.yaml --levels 0 --seconds 0.05)
set_tests_properties(cli.bench.sizes_scene_file_window PROPERTIES LABELS "cli;bench" PASS_REGULAR_EXPRESSION
  "scenarios/tube.yaml \\+ tube_insert from 1.8 s, 0.05 s")
# What replay warns of its inputs, bench sizes warns too: a recording made for another scene, and a
# window in which the tool never touched the tissue (free motion's costs).
add_test(NAME cli.bench.sizes_warns_of_its_inputs
  COMMAND ${EBH_BIN} bench sizes --scene tube_forceps --recording tube_insert --levels 0 --start 0 --seconds 0.05)
set_tests_properties(cli.bench.sizes_warns_of_its_inputs PROPERTIES LABELS "cli;bench" PASS_REGULAR_EXPRESSION
  "ebh: warning: .*tube_insert.h5: recorded for the scene 'tube' .*and replayed on 'tube_forceps'.*ebh: warning: level 0: the tool never touched the tissue in this window")
# A window running past the recording's end (tube_insert is 10 s long): measures the 0.25 s left,
# says so as replay does, and reports 0.25 s, not 1.
add_test(NAME cli.bench.sizes_window_past_end
  COMMAND ${EBH_BIN} bench sizes --levels 0 --start 9.75 --seconds 1 --json)
set_tests_properties(cli.bench.sizes_window_past_end PROPERTIES LABELS "cli;bench" PASS_REGULAR_EXPRESSION
  "ebh: warning: .*tube_insert.h5: the recording ends 0.25 s after --start; measuring those, not --seconds' 1 s\n.*\"start_s\": 9.75,\n +\"seconds\": 0.25,.*\"ticks\": 251,")
# The same for the sizes of a bench, before any size runs.
add_test(NAME cli.bench.sizes_no_limit
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--levels;0-20;--max-tets;9223372036854775807"
    "-DEXPECT=^ebh: error: --levels: level 20 of .*tube.yaml makes 9.29e\\+21 tets, over the 2147483647 tets or vertices a mesh can index"
    -DSTATUS=1 -DNO_STDOUT=1 -P ${EXPECT_FAILURE})
set_tests_properties(cli.bench.sizes_no_limit PROPERTIES TIMEOUT 60)
# A missing scene is said first, not that it has no default window.
add_test(NAME cli.bench.sizes_missing_scene
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--levels;0;--scene;${Z}/no_such/one.yaml"
    "-DEXPECT=^ebh: error: .*no_such/one.yaml: scene file not found" -DSTATUS=1 -DNO_STDOUT=1 -P ${EXPECT_FAILURE})
set_tests_properties(cli.bench.sizes_bad_levels cli.bench.sizes_levels_wrap cli.bench.sizes_levels_blank cli.bench.sizes_no_window
  cli.bench.sizes_no_window_start_given cli.bench.sizes_bad_override
  cli.bench.sizes_start_past_end cli.bench.sizes_missing_scene cli.bench.sizes_no_limit PROPERTIES LABELS "cli;bench")

# table1 and bench sizes on the CUDA backend where none can be used (no device visible, or a build
# without CUDA): one line that says so, exit status 1.
foreach(cmd "table1;--backend;cuda;--scene;tube;--seconds;0.2" "bench;sizes;--backend;cuda;--levels;0;--seconds;0.05")
  string(REGEX MATCH "^[a-z0-9]+" name "${cmd}")
  add_test(NAME cli.${name}.cuda_unavailable
    COMMAND ${CMAKE_COMMAND} -E env CUDA_VISIBLE_DEVICES= ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};${cmd}"
      "-DEXPECT=^ebh: error: --backend cuda: (this build has no CUDA backend \\(configure with -DEBH_WITH_CUDA=ON|no CUDA device.* on this machine)"
      -DSTATUS=1 -P ${EXPECT_FAILURE})
  set_tests_properties(cli.${name}.cuda_unavailable PROPERTIES LABELS cli)
endforeach()
