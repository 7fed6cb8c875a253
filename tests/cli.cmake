# Command-line tests: run `ebh` and check exit codes and messages. Each add_test here names what
# a user would type.
set(EBH_BIN $<TARGET_FILE:ebh>)
add_test(NAME cli.version COMMAND ${EBH_BIN} --version)
set_tests_properties(cli.version PROPERTIES PASS_REGULAR_EXPRESSION "ebh [0-9]+\\.[0-9]+" LABELS cli)

# ebh synth / ebh import (lib/io): a committed plan, the sample logs, bad input leaves no file.
set(EBH_IO_DATA ${CMAKE_CURRENT_SOURCE_DIR}/data/io)
set(EBH_IO_OUT ${PROJECT_BINARY_DIR}/cli_io)
file(MAKE_DIRECTORY ${EBH_IO_OUT})
add_test(NAME cli.synth.tube_insert
  COMMAND ${EBH_BIN} synth ${PROJECT_SOURCE_DIR}/recordings/tube_insert.yaml -o ${EBH_IO_OUT}/tube_insert.h5 --seed 1)
set_tests_properties(cli.synth.tube_insert PROPERTIES
  PASS_REGULAR_EXPRESSION "tube_insert.h5: 10001 samples, 10.000 s at 1000 Hz, scene tube, tool hook" LABELS cli)
add_test(NAME cli.import.openhaptics
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample_openhaptics.txt -o ${EBH_IO_OUT}/oh.h5 --scene tube --unit mm)
set_tests_properties(cli.import.openhaptics PROPERTIES PASS_REGULAR_EXPRESSION "oh.h5: 20 samples, 0.019 s, 1000 Hz" LABELS cli)
# A log in inches (a Polhemus tracker's default): the first sample's (10, -5, 30) in lands at 0.254 m.
add_test(NAME cli.import.inches
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample_openhaptics.txt -o ${EBH_IO_OUT}/oh_inches.h5 --scene tube --unit in)
set_tests_properties(cli.import.inches PROPERTIES PASS_REGULAR_EXPRESSION "starting at \\(0.254, -0.127, 0.762\\) m" LABELS cli)
add_test(NAME cli.import.csv
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample.csv -o ${EBH_IO_OUT}/csv.h5 --format csv --tool forceps)
set_tests_properties(cli.import.csv PROPERTIES PASS_REGULAR_EXPRESSION "csv.h5: 20 samples, 0.009[0-9]* s, 2000 Hz" LABELS cli)
# A ROS topic of poses exported to CSV (rostopic echo -p) imports as it is, the report naming
# each column it read.
add_test(NAME cli.import.ros_export COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample_ros.csv -o ${EBH_IO_OUT}/ros.h5)
set_tests_properties(cli.import.ros_export PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "ros.h5: 20 samples, 0.0095[0-9]* s, 2000 Hz, tool hook\n  read as a ROS export: %time as t \\(nanoseconds\\), field.pose.position.x as x, .*field.pose.orientation.w as qw; 3 other fields left unread\n")
# A ROS 1 bag as rosbag wrote it (tests/data/io/make_bags.py): its pose topic and gripper read,
# the report naming both and the clock; a ROS 2 MCAP file's tf frame (make_mcap.mjs); a bag of
# several pose topics is refused, naming them, and writes nothing. (Uncompressed files: the
# codecs are optional in a build; tests/io/test_rosbag.cpp reads the compressed ones.)
add_test(NAME cli.import.ros_bag COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample.bag -o ${EBH_IO_OUT}/bag.h5
  --jaw-topic /psm/jaw/measured_js --jaw-range 0,0.8 --tool forceps)
set_tests_properties(cli.import.ros_bag PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "bag.h5: 20 samples, 0.0095[0-9]* s, 2000 Hz, tool forceps\n  read as a ROS bag: topic /psm/measured_cp \\(geometry_msgs/PoseStamped, 20 messages\\), the jaw from /psm/jaw/measured_js \\(sensor_msgs/JointState, 20 messages; [^)]*\\); times from the messages' header stamps\n")
add_test(NAME cli.import.ros2_mcap COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample_none.mcap -o ${EBH_IO_OUT}/mcap.h5
  --frame psm1_tool)
set_tests_properties(cli.import.ros2_mcap PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "mcap.h5: 20 samples, 0.0095[0-9]* s, 2000 Hz, tool hook\n  read as a ROS 2 bag \\(MCAP\\): topic /tf \\(tf2_msgs/TFMessage, 20 messages; 20 transforms psm1_base -> psm1_tool\\); times from the messages' header stamps\n")
add_test(NAME cli.import.ros_bag_pose_topics
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};import;${EBH_IO_DATA}/topics.bag;-o;${EBH_IO_OUT}/topics.h5"
    "-DEXPECT=^ebh: error: .*topics.bag: several pose topics: /psm1/measured_cp \\(geometry_msgs/PoseStamped, 20\\), .*name the device's with --topic"
    -DOUTPUT=${EBH_IO_OUT}/topics.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.import.bad_rotation
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};import;${EBH_IO_DATA}/bad_rotation.txt;-o;${EBH_IO_OUT}/bad.h5"
    "-DEXPECT=^ebh: error: .*bad_rotation.txt:14: the rotation part is not a rotation" -DOUTPUT=${EBH_IO_OUT}/bad.h5
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.synth.bad_plan
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};synth;${EBH_IO_DATA}/bad_plan.yaml;-o;${EBH_IO_OUT}/bad_plan.h5"
    "-DEXPECT=^ebh: error: .*bad_plan.yaml:[0-9]+: key 'waypoints\\[2\\].t': times must be strictly increasing"
    -DOUTPUT=${EBH_IO_OUT}/bad_plan.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# --rate below twice the tremor's band (the plan's default 8-12 Hz) would alias it.
add_test(NAME cli.synth.rate_below_the_tremor
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};synth;${PROJECT_SOURCE_DIR}/recordings/gap_insert.yaml;-o;${EBH_IO_OUT}/rate20.h5;--rate;20"
    "-DEXPECT=^ebh: error: --rate 20: 20 Hz samples cannot carry the tremor's band up to 12 Hz"
    -DOUTPUT=${EBH_IO_OUT}/rate20.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# A log whose jaw closes, imported for a hook scene without --tool: recorded as a hook's, said.
add_test(NAME cli.import.closing_jaw_on_a_hook_scene
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample.csv -o ${EBH_IO_OUT}/jaw_hook.h5 --scene gap)
set_tests_properties(cli.import.closing_jaw_on_a_hook_scene PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "sample.csv: the jaw closes to 0 \\(below the grasp threshold 0.2\\) at the recording's t = 0.009 s, but the scene's tool is a hook, so the recording says hook: a forceps log\\? give --tool forceps")
# A negative seed would wrap to 2^64 - 1 in the unsigned option.
add_test(NAME cli.synth.negative_seed
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};synth;${PROJECT_SOURCE_DIR}/recordings/gap_insert.yaml;-o;${EBH_IO_OUT}/seed.h5;--seed;-1"
    "-DEXPECT=^ebh: error: --seed: expected a whole number >= 0 \\(at most 2\\^64 - 1\\), got '-1'"
    -DOUTPUT=${EBH_IO_OUT}/seed.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.import.bad_rotation cli.synth.bad_plan cli.synth.rate_below_the_tremor cli.synth.negative_seed
  PROPERTIES LABELS cli)
# A plan names a scene file relative to itself; the recording, written two folders further down,
# names the same file relative to its own folder (where readers look; a name stays a name:
# cli.synth.tube_insert), and a path that names no file is refused. The scene is read for its keys,
# not its meshes (synth uses none).
set(EBH_PLAN_SCENE ${EBH_IO_OUT}/plan_scene)
file(MAKE_DIRECTORY ${EBH_PLAN_SCENE}/plans ${EBH_PLAN_SCENE}/mesh)
file(WRITE ${EBH_PLAN_SCENE}/mesh/organ.yaml "# its mesh is made later\nmesh: {physical: organ.msh}\ntool: {kind: hook}\n")
set(ebh_plan_waypoints "tool: hook\nwaypoints:\n  - {t: 0, position_mm: [0, 0, 10], rotvec_deg: [180, 0, 0]}\n  - {t: 0.01, position_mm: [0, 0, 9]}\n")
file(WRITE ${EBH_PLAN_SCENE}/plans/relative.yaml "scene: ../mesh/organ.yaml\n${ebh_plan_waypoints}")
file(WRITE ${EBH_PLAN_SCENE}/plans/missing.yaml "# the scene is not beside the plan\nscene: organ.yaml\n${ebh_plan_waypoints}")
add_test(NAME cli.synth.scene_relative_to_recording
  COMMAND ${EBH_BIN} synth ${EBH_PLAN_SCENE}/plans/relative.yaml -o ${EBH_PLAN_SCENE}/out/sub/deeper/press.h5)
set_tests_properties(cli.synth.scene_relative_to_recording PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "press.h5: 11 samples, 0.010 s at 1000 Hz, scene \\.\\./\\.\\./\\.\\./mesh/organ.yaml, tool hook")
add_test(NAME cli.synth.scene_missing
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};synth;${EBH_PLAN_SCENE}/plans/missing.yaml;-o;${EBH_PLAN_SCENE}/missing.h5"
    "-DEXPECT=^ebh: error: .*plans/missing.yaml:2: key 'scene': .*plans/organ.yaml: scene file not found \\(a path in a plan is relative to the plan's folder\\)"
    -DOUTPUT=${EBH_PLAN_SCENE}/missing.h5 -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.synth.scene_missing PROPERTIES LABELS cli)
# A file that is no scene (a log without an extension, as /etc/passwd) would be stored as the
# recording's scene: refused, naming the plan's line, the file and what it holds; no recording.
file(WRITE ${EBH_PLAN_SCENE}/mesh/press_log "t x y z\n0 1 2 3\n")
file(WRITE ${EBH_PLAN_SCENE}/plans/no_scene.yaml "scene: ../mesh/press_log\n${ebh_plan_waypoints}")
add_test(NAME cli.synth.scene_not_a_scene
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};synth;${EBH_PLAN_SCENE}/plans/no_scene.yaml;-o;${EBH_PLAN_SCENE}/no_scene.h5"
    "-DEXPECT=^ebh: error: .*plans/no_scene.yaml:1: key 'scene': .*mesh/press_log: not a scene file: a scene is a YAML map of keys \\(mesh, tool, \\.\\.\\.\\), this file holds 't x y z 0 1 2 3'"
    -DOUTPUT=${EBH_PLAN_SCENE}/no_scene.h5 -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# A plan's tool other than its scene's: every replay on the scene would move the scene's tool and
# say they differ (a device log's tool is the hardware's, which `ebh import` keeps; a plan's is a
# slip): refused at its line, naming both tools; no recording.
file(WRITE ${EBH_PLAN_SCENE}/plans/other_tool.yaml "scene: tube\ntool: forceps\nwaypoints:\n  - {t: 0, position_mm: [0, 0, 10], rotvec_deg: [180, 0, 0]}\n  - {t: 0.01, position_mm: [0, 0, 9]}\n")
add_test(NAME cli.synth.tool_not_the_scenes
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};synth;${EBH_PLAN_SCENE}/plans/other_tool.yaml;-o;${EBH_PLAN_SCENE}/other_tool.h5"
    "-DEXPECT=^ebh: error: .*plans/other_tool.yaml:2: key 'tool': forceps, but the scene 'tube' \\(.*scenarios/tube.yaml\\) moves a hook: .*write tool: hook, or name a scene whose tool is a forceps"
    -DOUTPUT=${EBH_PLAN_SCENE}/other_tool.h5 -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.synth.scene_not_a_scene cli.synth.tool_not_the_scenes PROPERTIES LABELS cli)
# A scene name found in no data folder: stored as given (it may be found at replay time), warned.
file(WRITE ${EBH_PLAN_SCENE}/plans/misspelt.yaml "scene: gapp\n${ebh_plan_waypoints}")
add_test(NAME cli.synth.scene_name_not_found
  COMMAND ${EBH_BIN} synth ${EBH_PLAN_SCENE}/plans/misspelt.yaml -o ${EBH_PLAN_SCENE}/misspelt.h5)
set_tests_properties(cli.synth.scene_name_not_found PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "ebh: warning: .*plans/misspelt.yaml:1: key 'scene': gapp: no such scene.*; the recording names it all the same")
# A plan without `tool` plans for its scene's tool (cholecystectomy's forceps); where the scene is
# in no data folder there is none to take: refused, no recording.
string(REPLACE "tool: hook\n" "" ebh_plan_waypoints_only "${ebh_plan_waypoints}")
file(WRITE ${EBH_PLAN_SCENE}/plans/no_tool.yaml "scene: cholecystectomy\n${ebh_plan_waypoints_only}")
add_test(NAME cli.synth.tool_from_the_scene
  COMMAND ${EBH_BIN} synth ${EBH_PLAN_SCENE}/plans/no_tool.yaml -o ${EBH_PLAN_SCENE}/no_tool.h5)
set_tests_properties(cli.synth.tool_from_the_scene PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "no_tool.h5: 11 samples, 0.010 s at 1000 Hz, scene cholecystectomy, tool forceps")
file(WRITE ${EBH_PLAN_SCENE}/plans/no_tool_misspelt.yaml "scene: gapp\n${ebh_plan_waypoints_only}")
add_test(NAME cli.synth.tool_missing_without_scene
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};synth;${EBH_PLAN_SCENE}/plans/no_tool_misspelt.yaml;-o;${EBH_PLAN_SCENE}/no_tool_misspelt.h5"
    "-DEXPECT=ebh: error: .*plans/no_tool_misspelt.yaml: key 'tool': missing, and the scene is none to take it from \\(gapp: no such scene .*\\): write tool: hook or tool: forceps"
    -DOUTPUT=${EBH_PLAN_SCENE}/no_tool_misspelt.h5 -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.synth.tool_missing_without_scene PROPERTIES LABELS cli)
# Repeated samples are reported and, with --drop-repeats, removed; a log without times says
# which rate it assumed; a given rate is stored exactly.
add_test(NAME cli.import.repeats COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/repeats.csv -o ${EBH_IO_OUT}/repeats.h5)
set_tests_properties(cli.import.repeats PROPERTIES PASS_REGULAR_EXPRESSION
  "repeats.h5: 6 samples, 0.005 s, 1000 Hz, tool hook\n  2 consecutive samples repeat the previous pose, jaw and buttons exactly \\(--drop-repeats removes 2, keeping 0 holds of repeats lasting more than 10 ms\\)")
# The log's last sample repeats the one before it and is kept: the recording keeps its length.
add_test(NAME cli.import.drop_repeats
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/repeats_openhaptics.txt -o ${EBH_IO_OUT}/dropped.h5 --rate 250 --drop-repeats)
set_tests_properties(cli.import.drop_repeats PROPERTIES PASS_REGULAR_EXPRESSION
  "dropped.h5: 4 samples, 0.016 s, 250 Hz, tool hook\n  dropped 1 sample that repeated the previous pose, jaw and buttons exactly; kept 0 holds"
  FAIL_REGULAR_EXPRESSION "warning")
# A hold at the end of the log (30 repeats: the device at rest) keeps its last sample, and with it
# the log's length and the still tool.
add_test(NAME cli.import.hold_at_end
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/hold_end.csv -o ${EBH_IO_OUT}/hold_end.h5 --drop-repeats)
set_tests_properties(cli.import.hold_at_end PROPERTIES PASS_REGULAR_EXPRESSION
  "hold_end.h5: 21 samples, 0.049 s, 1000 Hz, tool hook\n  dropped 29 samples that repeated the previous pose, jaw and buttons exactly; kept 1 hold \\(repeats lasting more than 10 ms: the device at rest\\)"
  FAIL_REGULAR_EXPRESSION "warning")
add_test(NAME cli.import.assumed_rate
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/repeats_openhaptics.txt -o ${EBH_IO_OUT}/assumed.h5)
set_tests_properties(cli.import.assumed_rate PROPERTIES PASS_REGULAR_EXPRESSION
  "ebh: warning: .*repeats_openhaptics.txt: the log has no times; assumed 1000 Hz \\(give --rate HZ\\)")
add_test(NAME cli.import.rate_not_used
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/repeats.csv -o ${EBH_IO_OUT}/rate_not_used.h5 --rate 500)
set_tests_properties(cli.import.rate_not_used PROPERTIES PASS_REGULAR_EXPRESSION
  "ebh: warning: .*repeats.csv: the log has a t column; --rate 500 is not used.*1000 Hz")
# A log whose samples all repeat the first: the tool still from its first sample to its last.
add_test(NAME cli.import.drop_all
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/all_repeats.txt -o ${EBH_IO_OUT}/all.h5 --drop-repeats)
set_tests_properties(cli.import.drop_all PROPERTIES PASS_REGULAR_EXPRESSION
  "all.h5: 2 samples, 0.002 s, 1000 Hz, tool hook\n  dropped 1 sample that repeated")
# A log stamped in milliseconds reads as a rate 1000 times too low: refused, naming the unit, no
# recording; with --time-unit s (the times are seconds) said and written.
file(WRITE ${EBH_IO_OUT}/ms.csv "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0,0,0.001,1,0,0,0\n2,0,0,0.002,1,0,0,0\n")
add_test(NAME cli.import.times_in_ms
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};import;${EBH_IO_OUT}/ms.csv;-o;${EBH_IO_OUT}/ms.h5"
    "-DEXPECT=^ebh: error: .*ms.csv: column t: the times give 1 Hz \\(a median interval of 1 s between 3 samples over 2 s\\), below 10 Hz; a device logs at 100 Hz to 10 kHz: the times look like milliseconds \\(1000 Hz\\): import again with --time-unit ms \\(--time-unit s keeps them as seconds\\)"
    -DOUTPUT=${EBH_IO_OUT}/ms.h5 -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.import.times_in_ms_as_seconds
  COMMAND ${EBH_BIN} import ${EBH_IO_OUT}/ms.csv -o ${EBH_IO_OUT}/ms_s.h5 --time-unit s)
set_tests_properties(cli.import.times_in_ms_as_seconds PROPERTIES FAIL_REGULAR_EXPRESSION "error:" PASS_REGULAR_EXPRESSION
  "ebh: warning: .*ms.csv: column t: the times give 1 Hz .*the times look like milliseconds \\(1000 Hz\\): import again with --time-unit ms")
# ... which --time-unit ms reads as such.
add_test(NAME cli.import.time_unit_ms COMMAND ${EBH_BIN} import ${EBH_IO_OUT}/ms.csv -o ${EBH_IO_OUT}/ms_read.h5 --time-unit ms)
set_tests_properties(cli.import.time_unit_ms PROPERTIES PASS_REGULAR_EXPRESSION "ms_read.h5: 3 samples, 0.002 s, 1000 Hz"
  FAIL_REGULAR_EXPRESSION "warning")
# The rate of a log with a gap (the logger missed 997 ms) is its median interval's, 1000 Hz, not
# the mean's over the span (6 intervals over 1.002 s: 5.99 Hz, below any device's).
file(WRITE ${EBH_IO_OUT}/gap.csv "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.001,0,0,0.001,1,0,0,0\n0.002,0,0,0.002,1,0,0,0\n"
  "0.003,0,0,0.003,1,0,0,0\n1,0,0,0.004,1,0,0,0\n1.001,0,0,0.005,1,0,0,0\n1.002,0,0,0.006,1,0,0,0\n")
add_test(NAME cli.import.rate_across_a_gap COMMAND ${EBH_BIN} import ${EBH_IO_OUT}/gap.csv -o ${EBH_IO_OUT}/gap.h5)
set_tests_properties(cli.import.rate_across_a_gap PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "gap.h5: 7 samples, 1.002 s, 1000 Hz, tool hook\n"
  FAIL_REGULAR_EXPRESSION "below 10 Hz")
# With --scene the recording's tool is the scene's; a --tool that differs is recorded, with a warning.
add_test(NAME cli.import.scene_tool
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample_openhaptics.txt -o ${EBH_IO_OUT}/scene_tool.h5 --scene tube_forceps)
set_tests_properties(cli.import.scene_tool PROPERTIES PASS_REGULAR_EXPRESSION "scene_tool.h5: 20 samples, .*, tool forceps\n"
  FAIL_REGULAR_EXPRESSION "warning: .*--tool")
add_test(NAME cli.import.tool_not_the_scenes
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample_openhaptics.txt -o ${EBH_IO_OUT}/tool_hook.h5 --scene tube_forceps
    --tool hook)
set_tests_properties(cli.import.tool_not_the_scenes PROPERTIES PASS_REGULAR_EXPRESSION
  "ebh: warning: .*sample_openhaptics.txt: --tool hook, but the scene's tool is a forceps: the recording says hook.*tool_hook.h5: 20 samples, .*, tool hook\n")
# --mirror names the axis of a left-handed log; anything else is refused before the log is read.
add_test(NAME cli.import.mirror_axis
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};import;${EBH_IO_DATA}/sample_openhaptics.txt;-o;${EBH_IO_OUT}/mirror.h5;--mirror;w"
    "-DEXPECT=^ebh: error: --mirror: expected the axis that runs the other way, x, y or z, got 'w'"
    -DOUTPUT=${EBH_IO_OUT}/mirror.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_property(TEST cli.import.repeats cli.import.drop_repeats cli.import.hold_at_end cli.import.assumed_rate
  cli.import.rate_not_used cli.import.drop_all cli.import.times_in_ms cli.import.times_in_ms_as_seconds cli.import.scene_tool
  cli.import.tool_not_the_scenes cli.import.mirror_axis APPEND PROPERTY LABELS cli)

# ebh metrics (lib/metrics): the committed synthetic press (tests/data/metrics/make_trace.py
# writes it: peak force 1.52 N, one contact episode, one tick over 1 ms) and unreadable inputs.
set(EBH_METRICS_DATA ${CMAKE_CURRENT_SOURCE_DIR}/data/metrics)
add_test(NAME cli.metrics.table COMMAND ${EBH_BIN} metrics ${EBH_METRICS_DATA}/press.h5 --episodes)
set_tests_properties(cli.metrics.table PROPERTIES
  PASS_REGULAR_EXPRESSION "peak \\|F\\| +1\\.52[0-9]* N.*haptic ticks over budget +1 > 1 ms.*episodes \\(contacts > 0" LABELS cli)
add_test(NAME cli.metrics.json COMMAND ${EBH_BIN} metrics ${EBH_METRICS_DATA}/press.h5 --json)
set_tests_properties(cli.metrics.json PROPERTIES
  PASS_REGULAR_EXPRESSION "\"finite\": true,.*\"episode_count\": 1,.*\"haptic_over_budget_ticks\": 1" LABELS cli)
add_test(NAME cli.metrics.not_hdf5
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};metrics;${EBH_METRICS_DATA}/make_trace.py"
    "-DEXPECT=^ebh: error: .*make_trace.py: not an HDF5 file" -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.metrics.missing_file
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};metrics;${EBH_METRICS_DATA}/no_such_replay.h5"
    "-DEXPECT=^ebh: error: .*no_such_replay.h5: cannot open: No such file or directory" -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.metrics.recording_not_replay
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};metrics;${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5"
    "-DEXPECT=^ebh: error: .*tube_insert.h5: a device recording \\(/trajectory\\), not a replay output \\(/haptic\\): replay it first"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.metrics.fft_window_huge
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};metrics;${EBH_METRICS_DATA}/press.h5;--fft-window;4294967296"
    "-DEXPECT=^ebh: error: --fft-window: expected a whole number in \\[2, 1048576\\], got '4294967296'"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# The help gives the limit the option checks (it said 2^40).
add_test(NAME cli.metrics.fft_window_help COMMAND ${EBH_BIN} metrics --help)
set_tests_properties(cli.metrics.fft_window_help PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "--fft-window UINT:in \\[2, 1048576\\]" FAIL_REGULAR_EXPRESSION "1099511627776")
add_test(NAME cli.metrics.fft_window_short
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};metrics;${EBH_METRICS_DATA}/press.h5;--fft-window;32"
    "-DEXPECT=^ebh: error: --fft-window: 32 ticks is below 64 \\(64 ms at the output's 1000 Hz\\), the shortest window whose bins place 30 Hz"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.metrics.not_hdf5 cli.metrics.missing_file cli.metrics.recording_not_replay
  cli.metrics.fft_window_huge cli.metrics.fft_window_short PROPERTIES LABELS cli)
# A file name that starts with dashes is read as an option: said as an unknown one (CLI11 said
# "replay is required", or that the argument "was not expected"), with the two ways to name such a
# file where one exists; after --, it is the file.
set(EBH_DASHES ${PROJECT_BINARY_DIR}/cli_dashes)
file(MAKE_DIRECTORY ${EBH_DASHES}/empty)
file(WRITE ${EBH_DASHES}/--x.h5 "not HDF5\n")
add_test(NAME cli.metrics.unknown_option
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};metrics;--x.h5"
    "-DEXPECT=^ebh: error: unknown option '--x.h5' \\(ebh metrics --help lists its options\\)\n$" -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.metrics.unknown_option PROPERTIES WORKING_DIRECTORY ${EBH_DASHES}/empty)
foreach(case "alone|--x.h5" "after_the_replay|${EBH_METRICS_DATA}/press.h5;--x.h5")
  string(REPLACE "|" ";" case "${case}")
  list(POP_FRONT case id)
  add_test(NAME cli.metrics.dashed_file_${id}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};metrics;${case}"
      "-DEXPECT=^ebh: error: unknown option '--x.h5' \\(a file of that name exists: write \\./--x\\.h5, or -- --x\\.h5: after --, no argument is an option\\)\n$"
      -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.metrics.dashed_file_${id} PROPERTIES WORKING_DIRECTORY ${EBH_DASHES} LABELS cli)
endforeach()
add_test(NAME cli.metrics.dashed_file_after_double_dash
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};metrics;--;--x.h5" "-DEXPECT=^ebh: error: --x.h5: not an HDF5 file" -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.metrics.dashed_file_after_double_dash PROPERTIES WORKING_DIRECTORY ${EBH_DASHES})
set_tests_properties(cli.metrics.unknown_option cli.metrics.dashed_file_after_double_dash PROPERTIES LABELS cli)
# scripts/plot_forces.py on the same trace, where Debian's python3 has h5py, matplotlib and numpy.
find_program(EBH_SYSTEM_PYTHON3 NAMES python3 PATHS /usr/bin NO_DEFAULT_PATH)
# A replay output whose global heap (its string attributes) is damaged: HDF5 copies a string by
# the size the file gives and crashes inside the library; the crash names the file in one line,
# status 1 (a bare "Segmentation fault", 139, before). The file is made by a standard-library script.
if(EBH_SYSTEM_PYTHON3)
  add_test(NAME cli.metrics.damaged_heap_setup
    COMMAND ${EBH_SYSTEM_PYTHON3} ${EBH_METRICS_DATA}/damage_heap.py ${EBH_METRICS_DATA}/press.h5
      ${PROJECT_BINARY_DIR}/damaged_heap.h5)
  set_tests_properties(cli.metrics.damaged_heap_setup PROPERTIES FIXTURES_SETUP damaged_heap LABELS cli)
  # Status 1 and our line; the C library may print its own line first ("free(): invalid pointer"
  # where the damage makes HDF5 free what it never allocated: SIGABRT), which no handler can stop.
  add_test(NAME cli.metrics.damaged_heap COMMAND sh -c
    "'${EBH_BIN}' metrics '${PROJECT_BINARY_DIR}/damaged_heap.h5' 2>'${PROJECT_BINARY_DIR}/damaged_heap.err'; test $? -eq 1 && grep -E '^ebh: error: .*damaged_heap.h5: the process crashed \\(SIG(SEGV|ABRT|BUS)\\) while reading it: the file is damaged where the HDF5 library trusts it' '${PROJECT_BINARY_DIR}/damaged_heap.err'")
  set_tests_properties(cli.metrics.damaged_heap PROPERTIES FIXTURES_REQUIRED damaged_heap LABELS cli)
endif()
if(EBH_SYSTEM_PYTHON3)
  execute_process(COMMAND ${EBH_SYSTEM_PYTHON3} -c "import h5py, matplotlib, numpy"
    RESULT_VARIABLE ebh_plot_deps OUTPUT_QUIET ERROR_QUIET)
  if(ebh_plot_deps EQUAL 0)
    add_test(NAME cli.plot_forces
      COMMAND ${EBH_SYSTEM_PYTHON3} ${PROJECT_SOURCE_DIR}/scripts/plot_forces.py ${EBH_METRICS_DATA}/press.h5
        -o ${PROJECT_BINARY_DIR}/plot_forces_press.png --labels press)
    set_tests_properties(cli.plot_forces PROPERTIES PASS_REGULAR_EXPRESSION "plot_forces_press.png" LABELS cli)
    # An output named like its input, in a folder that is not there, or a recording for a replay:
    # one line, exit status 1 (matplotlib's traceback before).
    add_test(NAME cli.plot_forces_over_its_input
      COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_SYSTEM_PYTHON3};${PROJECT_SOURCE_DIR}/scripts/plot_forces.py;${EBH_METRICS_DATA}/press.h5;-o;${EBH_METRICS_DATA}/press.h5"
        "-DEXPECT=^plot_forces.py: error: .*press.h5: the plot is a PNG file" "-DKEEP=${EBH_METRICS_DATA}/press.h5" -DSTATUS=1
        -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
    add_test(NAME cli.plot_forces_no_folder
      COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_SYSTEM_PYTHON3};${PROJECT_SOURCE_DIR}/scripts/plot_forces.py;${EBH_METRICS_DATA}/press.h5;-o;${PROJECT_BINARY_DIR}/no_such_folder/f.png"
        "-DEXPECT=^plot_forces.py: error: .*f.png: the folder .*no_such_folder does not exist" -DSTATUS=1
        -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
    add_test(NAME cli.plot_forces_recording
      COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_SYSTEM_PYTHON3};${PROJECT_SOURCE_DIR}/scripts/plot_forces.py;${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5;-o;${PROJECT_BINARY_DIR}/rec.png"
        "-DEXPECT=^plot_forces.py: error: .*tube_insert.h5: a device recording \\(/trajectory\\), not a replay output" -DSTATUS=1
        -DOUTPUT=${PROJECT_BINARY_DIR}/rec.png -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
    # A time that is no number (--t0 nan) is named, not "no ticks between --t0 and --t1".
    add_test(NAME cli.plot_forces_nan_time
      COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_SYSTEM_PYTHON3};${PROJECT_SOURCE_DIR}/scripts/plot_forces.py;${EBH_METRICS_DATA}/press.h5;-o;${PROJECT_BINARY_DIR}/nan.png;--t0;nan"
        "-DEXPECT=^plot_forces.py: error: --t0 nan: expected a finite time in s" -DSTATUS=1
        -DOUTPUT=${PROJECT_BINARY_DIR}/nan.png -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
    set_tests_properties(cli.plot_forces_over_its_input cli.plot_forces_no_folder cli.plot_forces_recording
      cli.plot_forces_nan_time PROPERTIES
      LABELS cli)
  endif()
endif()

# A mesh or a recording given where a scene goes is named as what it is.
add_test(NAME cli.scene.info_of_a_mesh
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;info;${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube22.msh"
    "-DEXPECT=^ebh: error: .*cube22.msh: not a scene file: a scene is a YAML map of keys .*; it is a Gmsh mesh: `ebh scene init"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.recording_as_scene
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5;tube_insert;-o;${PROJECT_BINARY_DIR}/never_written.h5"
    "-DEXPECT=^ebh: error: .*tube_insert.h5: an HDF5 file \\(a recording or a replay output\\?\\), not a scene file"
    -DOUTPUT=${PROJECT_BINARY_DIR}/never_written.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene.info_of_a_mesh cli.replay.recording_as_scene PROPERTIES LABELS cli)

# A count given as a fraction, beyond its type or below 1 is one line naming the option and its
# range (CLI11: "Could not convert: --every = 1.5", or a 300-digit bound).
foreach(case "render;${EBH_METRICS_DATA}/press.h5;-o;${PROJECT_BINARY_DIR}/never_rendered;--every;1.5|--every: expected a whole number in \\[1, 2147483647\\], got '1\\.5'"
             "metrics;${EBH_METRICS_DATA}/press.h5;--fft-window;1e30|--fft-window: expected a whole number in \\[2, 1048576\\], got '1e30'"
             "bench;sizes;--max-tets;-5|--max-tets: expected a whole number in \\[1, 9223372036854775807\\], got '-5'"
             "replay;tube;tube_insert;-o;${PROJECT_BINARY_DIR}/never_replayed.h5;--haptic-threads;2.5|--haptic-threads: expected a whole number in \\[1, 4096\\], got '2\\.5'")
  string(REPLACE "|" ";" parts "${case}")
  list(GET parts -1 expect)
  list(REMOVE_AT parts -1)
  list(GET parts 0 command)
  add_test(NAME cli.whole_number.${command}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};${parts}" "-DEXPECT=^ebh: error: ${expect}\n" -DSTATUS=1
      -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.whole_number.${command} PROPERTIES LABELS cli)
endforeach()

# A scenarios/ folder in the working directory holding another tube.yaml than ebh's own: the name
# finds it first, and the replay says so; an identical copy is not said.
foreach(kind same other)
  set(dir ${PROJECT_BINARY_DIR}/cli_shadow_${kind})
  file(MAKE_DIRECTORY ${dir}/scenarios)
  file(COPY ${PROJECT_SOURCE_DIR}/scenarios/tube.msh DESTINATION ${dir}/scenarios)
  file(READ ${PROJECT_SOURCE_DIR}/scenarios/tube.yaml ebh_tube_yaml)
  if(kind STREQUAL other)
    string(APPEND ebh_tube_yaml "# edited: another file than ebh's own\n")
  endif()
  file(WRITE ${dir}/scenarios/tube.yaml "${ebh_tube_yaml}")
  add_test(NAME cli.replay.shadowed_scene_${kind}
    COMMAND ${EBH_BIN} replay tube tube_insert -o ${dir}/out.h5 --start 4 --duration 0.05 -q WORKING_DIRECTORY ${dir})
  set_tests_properties(cli.replay.shadowed_scene_${kind} PROPERTIES LABELS cli)
endforeach()
set_tests_properties(cli.replay.shadowed_scene_other PROPERTIES PASS_REGULAR_EXPRESSION
  "ebh: warning: tube: the scene [^\n]*cli_shadow_other/scenarios/tube.yaml is used, not ebh's own [^\n]*/scenarios/tube.yaml, which differs: a name is looked up in \\$EBH_DATA_DIR, the working directory, then ebh's source tree")
set_tests_properties(cli.replay.shadowed_scene_same PROPERTIES FAIL_REGULAR_EXPRESSION "ebh's own")

# A scene reached through a linked folder whose mesh is named '../meshes/tube.msh': the OS's '..'
# (the link target's parent), not the text's (alias/meshes, file not found).
set(dir ${PROJECT_BINARY_DIR}/cli_linked)
file(MAKE_DIRECTORY ${dir}/proj/scenes ${dir}/proj/meshes ${dir}/alias)
file(COPY ${PROJECT_SOURCE_DIR}/scenarios/tube.msh DESTINATION ${dir}/proj/meshes)
file(READ ${PROJECT_SOURCE_DIR}/scenarios/tube.yaml ebh_tube_yaml)
string(REPLACE "physical: tube.msh" "physical: ../meshes/tube.msh" ebh_tube_yaml "${ebh_tube_yaml}")
file(WRITE ${dir}/proj/scenes/s.yaml "${ebh_tube_yaml}")
file(CREATE_LINK ${dir}/proj/scenes ${dir}/alias/sc SYMBOLIC)
add_test(NAME cli.scene.through_a_linked_folder COMMAND ${EBH_BIN} scene info alias/sc/s.yaml WORKING_DIRECTORY ${dir})
set_tests_properties(cli.scene.through_a_linked_folder PROPERTIES PASS_REGULAR_EXPRESSION
  "physical mesh +alias/sc/\\.\\./meshes/tube\\.msh\n.*tets +8057" LABELS "cli;scene")

# An output name of 255 bytes: written without mesh snapshots (its XDMF index's name, 257 bytes,
# is none of the replay's files then); with them, refused before any work, naming the index.
string(REPEAT "L" 252 ebh_long_name)
string(REPEAT "L" 250 ebh_long_name_f)
add_test(NAME cli.replay.longest_name
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${PROJECT_BINARY_DIR}/${ebh_long_name}.h5 --start 4 --duration 0.05 -q
    --frames-hz 0)
set_tests_properties(cli.replay.longest_name PROPERTIES FAIL_REGULAR_EXPRESSION "error" LABELS cli)
add_test(NAME cli.replay.longest_name_with_frames
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${PROJECT_BINARY_DIR}/${ebh_long_name_f}_f.h5;--start;4;--duration;0.05;--frames-hz;10"
    "-DEXPECT=^ebh: error: [^\n]*L_f\\.xdmf: cannot create the output: File name too long" -DSTATUS=1
    -DOUTPUT=${PROJECT_BINARY_DIR}/${ebh_long_name_f}_f.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.replay.longest_name_with_frames PROPERTIES LABELS cli)

# "-o=out.h5" (CLI11 and getopt give -o the value "=out.h5"): refused, naming the two ways.
add_test(NAME cli.short_option_with_equals
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o=${PROJECT_BINARY_DIR}/eq.h5;--duration;0.05"
    "-DEXPECT=^ebh: error: '-o=[^']*/eq.h5': a short option takes its value after a space \\(-o [^ ]*/eq.h5\\), not after '='"
    -DSTATUS=1 -DNO_STDOUT=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.short_option_with_equals PROPERTIES LABELS cli)

# A first word that is no command names the commands.
add_test(NAME cli.unknown_command
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replya;tube;tube_insert"
    "-DEXPECT=^ebh: error: 'replya' is not an ebh command \\(commands: bench, gate, import, metrics, render, replay,"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.unknown_command PROPERTIES LABELS cli)

# ebh scene info (tests/data/scene)
add_test(NAME cli.scene.info COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_SOURCE_DIR}/data/scene/cube.yaml)
set_tests_properties(cli.scene.info PROPERTIES PASS_REGULAR_EXPRESSION "tets +5\n" LABELS "cli;scene")
add_test(NAME cli.scene.info_json COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_SOURCE_DIR}/data/scene/cube_obj.yaml --json)
set_tests_properties(cli.scene.info_json PROPERTIES PASS_REGULAR_EXPRESSION "\"tets\": 5,.*\"interior_faces\": 4" LABELS "cli;scene")
# A virtual mesh in m read as cm (1/100 of the cube): scene info says so, as a replay would.
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_tiny.obj
  "v 0 0 0\nv .1 0 0\nv 0 .1 0\nv .1 .1 0\nv 0 0 .1\nv .1 0 .1\nv 0 .1 .1\nv .1 .1 .1\n"
  "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n")
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_tiny.yaml
  "unit: cm\nmesh: {physical: ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube41.msh, virtual: cli_scene_tiny.obj}\n"
  "pinned:\n  - sphere: {center: [0, 0, 0], radius: 0.5}\n")
add_test(NAME cli.scene.info_virtual_unit COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_tiny.yaml)
set_tests_properties(cli.scene.info_virtual_unit PROPERTIES LABELS "cli;scene" PASS_REGULAR_EXPRESSION
  "warning: .*cli_scene_tiny.obj: mesh.virtual: the virtual mesh spans 1.73 mm, 1/100 of the physical mesh's diagonal")
# Every vertex pinned: warned, and the solver's lines say there is nothing to solve (not an infinite rate).
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_all_pinned.yaml
  "unit: cm\nmesh: {physical: ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube41.msh}\n"
  "pinned:\n  - box: {min: [-1, -1, -1], max: [11, 11, 11]}\n")
add_test(NAME cli.scene.info_all_pinned COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_all_pinned.yaml)
set_tests_properties(cli.scene.info_all_pinned PROPERTIES LABELS "cli;scene"
  PASS_REGULAR_EXPRESSION "every vertex of the physical mesh is pinned.*physical solver +nothing to solve: every vertex is pinned"
  FAIL_REGULAR_EXPRESSION "inf iterations|lambda_max")
add_test(NAME cli.scene.missing COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_SOURCE_DIR}/data/scene/no_such_scene.yaml)
set_tests_properties(cli.scene.missing PROPERTIES WILL_FAIL TRUE LABELS "cli;scene")
add_test(NAME cli.scene.missing_message COMMAND ${EBH_BIN} scene info no_such_scene_name)
set_tests_properties(cli.scene.missing_message PROPERTIES PASS_REGULAR_EXPRESSION "ebh: error: no_such_scene_name: no such scene" LABELS "cli;scene")
# a bad key: the scene file is written at test time so the data folder holds only valid scenes
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_bad_key.yaml
  "mesh: {physical: ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube22.msh}\ntool: {hook: {tip_length: abc}}\n")
add_test(NAME cli.scene.bad_key COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_bad_key.yaml)
set_tests_properties(cli.scene.bad_key PROPERTIES WILL_FAIL TRUE LABELS "cli;scene")
add_test(NAME cli.scene.bad_key_message COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_bad_key.yaml)
set_tests_properties(cli.scene.bad_key_message PROPERTIES
  PASS_REGULAR_EXPRESSION "key 'tool.hook.tip_length': expected a positive number, got 'abc'" LABELS "cli;scene")

# 100000 nested lists: yaml-cpp's nesting limit, one line naming the file (no stack overflow).
string(REPEAT "[" 100000 ebh_deep)
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_deep.yaml "gravity: ${ebh_deep}\n")
add_test(NAME cli.scene.nested_too_deeply
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;info;${CMAKE_CURRENT_BINARY_DIR}/cli_scene_deep.yaml"
    "-DEXPECT=^ebh: error: .*cli_scene_deep.yaml:[0-9]+: nested too deeply \\(over 500 levels of lists and maps" -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene.nested_too_deeply PROPERTIES LABELS "cli;scene")
# ... under a 64 KiB stack limit too (yaml-cpp's recursion ran out of it before its limit: SIGSEGV).
add_test(NAME cli.scene.nested_too_deeply_small_stack
  COMMAND ${CMAKE_COMMAND}
    "-DCMD=sh;-c;ulimit -s 64 && exec \"$0\" scene info \"$1\";${EBH_BIN};${CMAKE_CURRENT_BINARY_DIR}/cli_scene_deep.yaml"
    "-DEXPECT=^ebh: error: .*cli_scene_deep.yaml:[0-9]+: nested too deeply \\(over 500 levels of lists and maps" -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene.nested_too_deeply_small_stack PROPERTIES LABELS "cli;scene")

# scene info shows the contact model; with surface contact, the samples' spacing and the stiffness
# after the floor (a 1 mm tip and the 3.3 N limit raise the default 400 N/m to 2200).
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_surface.yaml
  "unit: mm\nmesh: {physical: ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube22.msh, unit: m}\ncontact: surface\n"
  "tool: {kind: hook, shaft_radius: 2.5, hook: {tip_length: 6, tip_radius: 1}, force_limit: 3.3}\n"
  "stiffness: {k_con: 400}\nstages: {settle: false}\n")
add_test(NAME cli.scene.info_surface_contact COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_surface.yaml)
set_tests_properties(cli.scene.info_surface_contact PROPERTIES
  PASS_REGULAR_EXPRESSION "contact +surface: samples every 1 mm .*stiffness 2200 N/m per sample of full weight \\(raised"
  LABELS "cli;scene")
add_test(NAME cli.scene.info_vertex_contact COMMAND ${EBH_BIN} scene info tube)
set_tests_properties(cli.scene.info_vertex_contact PROPERTIES PASS_REGULAR_EXPRESSION "contact +vertices" LABELS "cli;scene")

# scene info shows the tool next to the mesh's bounding box, each in its unit; a scene switched to
# a cm mesh with its tool sizes still in mm numbers warns, naming the keys, in scene info and replay.
add_test(NAME cli.scene.info_tool COMMAND ${EBH_BIN} scene info cholecystectomy)
set_tests_properties(cli.scene.info_tool PROPERTIES LABELS "cli;scene" FAIL_REGULAR_EXPRESSION "warning"
  PASS_REGULAR_EXPRESSION "  unit +mm, no transform\n.*  in mm +\\[-94\\.9678, .*diagonal 270\\.856\\)\ntool +forceps, sizes in mm \\(tool\\.unit\\).*\n  shaft +radius 3, length 300 mm\n  jaws +length 20, width 5, thickness 2 mm")
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_tool_in_mm_numbers.yaml
  "unit: cm\nmesh: {physical: ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube22.msh}\npinned: [{group: bottom}]\n"
  "tool: {kind: forceps, shaft_radius: 2.5, shaft_length: 300, forceps: {jaw_length: 20}}\n")
set(EBH_TOOL_WARNING "ebh: warning: .*cli_scene_tool_in_mm_numbers.yaml: tool.shaft_length = 300 cm \\(3 m\\): laparoscopic shafts are about 0.3-0.45 m long; is tool.unit \\(cm\\) right\\?")
add_test(NAME cli.scene.info_tool_unit_warning
  COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_tool_in_mm_numbers.yaml)
add_test(NAME cli.replay.tool_unit_warning
  COMMAND ${EBH_BIN} replay ${CMAKE_CURRENT_BINARY_DIR}/cli_scene_tool_in_mm_numbers.yaml tube_insert
    -o ${PROJECT_BINARY_DIR}/cli_scene_tool_unit_warning.h5 --duration 0.01 -q)
set_tests_properties(cli.scene.info_tool_unit_warning cli.replay.tool_unit_warning PROPERTIES LABELS "cli;scene"
  PASS_REGULAR_EXPRESSION "${EBH_TOOL_WARNING}")

# ebh scene init (lib/scene/scene_init.hpp): a segmentation-like mesh in cm without physical groups
# (a 4 x 3 x 2 cm box of 5 tets) becomes a scene that scene info reads and a synthetic press replays,
# with the tool in mm; bad pins, a mesh that does not load and an output over the mesh are one-line
# errors that leave no file.
set(EBH_INIT ${PROJECT_BINARY_DIR}/cli_scene_init)
file(MAKE_DIRECTORY ${EBH_INIT})
file(WRITE ${EBH_INIT}/own_cm.msh "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n8\n1 0 0 0\n2 4 0 0\n3 0 3 0\n4 4 3 0\n"
  "5 0 0 2\n6 4 0 2\n7 0 3 2\n8 4 3 2\n$EndNodes\n$Elements\n5\n1 4 0 1 2 3 5\n2 4 0 4 3 2 8\n3 4 0 6 5 8 2\n"
  "4 4 0 7 8 5 3\n5 4 0 2 3 5 8\n$EndElements\n")
file(WRITE ${EBH_INIT}/not_a_mesh.msh "a segmentation exported as text, not Gmsh\n")
# the hook comes down on the box's top face (z = 2 cm) at its centre and presses 3 mm in
file(WRITE ${EBH_INIT}/press.yaml "scene: own\ntool: hook\nwaypoints:\n"
  "  - {t: 0.0, position_mm: [20, 15, 40], rotvec_deg: [180, 0, 0], jaw: 1}\n  - {t: 0.2, position_mm: [20, 15, 40]}\n"
  "  - {t: 0.6, position_mm: [20, 15, 17]}\n  - {t: 0.8, position_mm: [20, 15, 17]}\n")
# An MSH 4.1 file without $Entities: its $PhysicalNames name groups no element is in.
file(READ ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube41.msh EBH_CUBE41)
string(REGEX REPLACE "\\$Entities.*\\$EndEntities\n" "" EBH_CUBE41_NO_ENTITIES "${EBH_CUBE41}")
file(WRITE ${EBH_INIT}/no_entities41.msh "${EBH_CUBE41_NO_ENTITIES}")
add_test(NAME cli.scene_init.group_without_entities
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;init;${EBH_INIT}/no_entities41.msh;-o;${EBH_INIT}/no_entities.yaml;--unit;cm;--pin;group:bottom"
    "-DEXPECT=^ebh: error: --pin group:bottom: the region pins no vertex of .*no_entities41.msh: the mesh file names the group, but no element of it is in the group \\(MSH 4.1 gives elements their groups through its \\$Entities section"
    -DOUTPUT=${EBH_INIT}/no_entities.yaml -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene_init.group_without_entities PROPERTIES LABELS cli)
# MSH 4.1 as meshio writes it: its surfaces' element blocks on entities $Entities does not list.
# The file reads (without the triangles' groups); a pin by their group names why it is empty.
string(REPLACE "2 2 2 2\n" "2 9 2 2\n" EBH_CUBE41_MESHIO "${EBH_CUBE41}")
file(WRITE ${EBH_INIT}/meshio41.msh "${EBH_CUBE41_MESHIO}")
add_test(NAME cli.scene_init.group_on_unlisted_entities
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;init;${EBH_INIT}/meshio41.msh;-o;${EBH_INIT}/meshio41.yaml;--unit;cm;--pin;group:top"
    "-DEXPECT=^ebh: error: --pin group:top: the region pins no vertex of .*meshio41.msh: the mesh file names the group, but 2 of its triangles and tets, from line 54, lie on entities that its \\$Entities section does not list \\(MSH 4.1 as meshio writes it\\).*file_format=\"gmsh22\""
    -DOUTPUT=${EBH_INIT}/meshio41.yaml -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# A physical curve is not a pin's group: said so, not "no physical group".
add_test(NAME cli.scene_init.pin_group_of_curves
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;init;${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube41.msh;-o;${EBH_INIT}/curve_pin.yaml;--unit;cm;--pin;group:edge"
    "-DEXPECT=^ebh: error: --pin group:edge: .*cube41.msh has no physical group 'edge' \\(its groups: [^)]*\\): 'edge' is a physical group of curves in the mesh file, and pins take groups of tets or triangles"
    -DOUTPUT=${EBH_INIT}/curve_pin.yaml -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene_init.group_on_unlisted_entities cli.scene_init.pin_group_of_curves PROPERTIES LABELS cli)
add_test(NAME cli.scene_init.write
  COMMAND ${EBH_BIN} scene init ${EBH_INIT}/own_cm.msh -o ${EBH_INIT}/own.yaml --unit cm --tissue liver)
set_tests_properties(cli.scene_init.write PROPERTIES FIXTURES_SETUP scene_init FAIL_REGULAR_EXPRESSION "warning"
  PASS_REGULAR_EXPRESSION "own.yaml: scene for .*own_cm.msh \\(8 vertices, 5 tets, in cm\\), liver, hook\n  no --pin given: pinned the lowest 5% of the mesh's height \\(z <= 0.1 cm, 4 vertices\\)")
# The hint to check a scene named with a space and a '#' quotes it as a shell reads it back.
add_test(NAME cli.scene_init.hint_quoted
  COMMAND ${EBH_BIN} scene init ${EBH_INIT}/own_cm.msh -o "${EBH_INIT}/my scene #1.yaml" --unit cm --tissue liver)
set_tests_properties(cli.scene_init.hint_quoted PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "  check it: ebh scene info '[^'\n]*/my scene #1\\.yaml'\n")
add_test(NAME cli.scene_init.info COMMAND ${EBH_BIN} scene info ${EBH_INIT}/own.yaml)
set_tests_properties(cli.scene_init.info PROPERTIES FIXTURES_REQUIRED scene_init FAIL_REGULAR_EXPRESSION "warning"
  PASS_REGULAR_EXPRESSION "unit +cm, no transform.*pinned vertices +4\n.*  in cm +\\[0, 0, 0\\] \\.\\. \\[4, 3, 2\\].*tool +hook, sizes in mm.*\n  shaft +radius 2.5, length 330 mm")
add_test(NAME cli.scene_init.synth COMMAND ${EBH_BIN} synth ${EBH_INIT}/press.yaml -o ${EBH_INIT}/press.h5)
set_tests_properties(cli.scene_init.synth PROPERTIES FIXTURES_SETUP scene_init_press)
add_test(NAME cli.scene_init.replay
  COMMAND ${EBH_BIN} replay ${EBH_INIT}/own.yaml ${EBH_INIT}/press.h5 -o ${EBH_INIT}/press_out.h5)
set_tests_properties(cli.scene_init.replay PROPERTIES FIXTURES_REQUIRED "scene_init;scene_init_press"
  PASS_REGULAR_EXPRESSION "801 ticks, 81 physical steps.*peak force 0\\.[0-9]+ N" FAIL_REGULAR_EXPRESSION "warning|never touched")
# A VTK legacy mesh (binary): read as the physical mesh, pinned by its region 1 (gmsh:physical).
add_test(NAME cli.scene_init.vtk
  COMMAND ${EBH_BIN} scene init ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube_binary.vtk -o ${EBH_INIT}/cube_vtk.yaml --unit cm
    --pin group:1)
set_tests_properties(cli.scene_init.vtk PROPERTIES LABELS "cli;scene" FIXTURES_SETUP scene_init_vtk
  PASS_REGULAR_EXPRESSION "cube_vtk.yaml: scene for .*cube_binary.vtk \\(8 vertices, 5 tets, in cm\\).*pinned 6 vertices \\(group:1\\)")
add_test(NAME cli.scene_init.vtk_info COMMAND ${EBH_BIN} scene info ${EBH_INIT}/cube_vtk.yaml)
set_tests_properties(cli.scene_init.vtk_info PROPERTIES LABELS "cli;scene" FIXTURES_REQUIRED scene_init_vtk
  PASS_REGULAR_EXPRESSION "physical mesh +[^\n]*cube_binary.vtk\n.*tets +5\n")
# A TetGen mesh (named by its .ele; .node and .face beside it), pinned by a face marker's group,
# and a Medit mesh pinned by a tet reference.
add_test(NAME cli.scene_init.tetgen
  COMMAND ${EBH_BIN} scene init ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube.1.ele -o ${EBH_INIT}/cube_tetgen.yaml --unit cm
    --pin group:surface_3)
set_tests_properties(cli.scene_init.tetgen PROPERTIES LABELS "cli;scene" FIXTURES_SETUP scene_init_tetgen
  PASS_REGULAR_EXPRESSION "cube_tetgen.yaml: scene for .*cube.1.ele \\(8 vertices, 5 tets, in cm\\).*pinned 4 vertices \\(group:surface_3\\)")
add_test(NAME cli.scene_init.tetgen_info COMMAND ${EBH_BIN} scene info ${EBH_INIT}/cube_tetgen.yaml)
set_tests_properties(cli.scene_init.tetgen_info PROPERTIES LABELS "cli;scene" FIXTURES_REQUIRED scene_init_tetgen
  PASS_REGULAR_EXPRESSION "tets +5\n.*surface_1 +tag 1 +0 tets +2 triangles\n  surface_3 +tag 3 +0 tets +2 triangles")
add_test(NAME cli.scene_init.medit
  COMMAND ${EBH_BIN} scene init ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube.mesh -o ${EBH_INIT}/cube_medit.yaml --unit cm
    --pin group:1)
set_tests_properties(cli.scene_init.medit PROPERTIES LABELS "cli;scene"
  PASS_REGULAR_EXPRESSION "cube_medit.yaml: scene for .*cube.mesh \\(8 vertices, 5 tets, in cm\\).*pinned 6 vertices \\(group:1\\)")
add_test(NAME cli.scene.info_of_a_medit_mesh
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;info;${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube.mesh"
    "-DEXPECT=^ebh: error: .*cube.mesh: a Medit mesh, not a scene file \\(YAML\\): `ebh scene init .*cube.mesh -o scene.yaml` writes a scene for it"
    -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene.info_of_a_medit_mesh PROPERTIES LABELS "cli;scene")
add_test(NAME cli.scene.info_of_a_surface
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;info;${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube_poly.vtk"
    "-DEXPECT=^ebh: error: .*cube_poly.vtk: a VTK mesh, not a scene file \\(YAML\\): a surface is a scene's mesh.virtual"
    -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene.info_of_a_surface PROPERTIES LABELS "cli;scene")
add_test(NAME cli.scene.info_stiffness_regions COMMAND ${EBH_BIN} scene info ${CMAKE_CURRENT_SOURCE_DIR}/data/scene/cube_regions.yaml)
set_tests_properties(cli.scene.info_stiffness_regions PROPERTIES LABELS "cli;scene"
  PASS_REGULAR_EXPRESSION "stiffness +k_vol 2500 Pa, with 2 regions:\n  \\[0\\] group +k_vol 7000 Pa: 5 tets \\(2 keep it\\)\n  \\[1\\] box +k_vol 5000 Pa: 3 tets \\(3 keep it\\)\n")
function(ebh_scene_init_failure name expect)
  add_test(NAME cli.scene_init.${name}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;init;${ARGN}" "-DEXPECT=${expect}" -DSTATUS=1
      -DOUTPUT=${EBH_INIT}/${name}.yaml -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.scene_init.${name} PROPERTIES LABELS "cli;scene")
endfunction()
set(OWN ${EBH_INIT}/own_cm.msh)
ebh_scene_init_failure(group_missing "^ebh: error: --pin group:liver: .*own_cm.msh has no physical group 'liver' \\(it has no groups\\)"
  ${OWN} -o ${EBH_INIT}/group_missing.yaml --unit cm --pin group:liver)
add_test(NAME cli.scene.info_of_a_vtk_mesh
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;info;${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube_binary.vtk"
    "-DEXPECT=^ebh: error: .*cube_binary.vtk: a VTK mesh, not a scene file \\(YAML\\): `ebh scene init .*cube_binary.vtk -o scene.yaml` writes a scene for it"
    -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene.info_of_a_vtk_mesh PROPERTIES LABELS "cli;scene")
ebh_scene_init_failure(vtk_group "^ebh: error: --pin group:bottom: .*cube51.vtk has no physical group 'bottom' \\(it has no groups\\): a VTK file's groups are the numbers in its cell array named gmsh:physical, .*; or pin a box or a half-space"
  ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube51.vtk -o ${EBH_INIT}/vtk_group.yaml --unit cm --pin group:bottom)
ebh_scene_init_failure(vtu_group "^ebh: error: --pin group:bottom: .*cube_ascii.vtu has no physical group 'bottom' \\(its groups: 1 \\(unnamed\\), 2 \\(unnamed\\)\\): a VTK file's groups are the numbers in its cell array named gmsh:physical, .*; or pin a box or a half-space"
  ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube_ascii.vtu -o ${EBH_INIT}/vtu_group.yaml --unit cm --pin group:bottom)
ebh_scene_init_failure(tetgen_group "^ebh: error: --pin group:9: .*cube0.node has no physical group '9' \\(it has no groups\\): a TetGen mesh's groups are its region attributes \\(by number, tetgen -A\\) and its faces' boundary markers \\(surface_N\\); or pin a box or a half-space"
  ${CMAKE_CURRENT_SOURCE_DIR}/data/mesh/cube0.node -o ${EBH_INIT}/tetgen_group.yaml --unit cm --pin group:9)
ebh_scene_init_failure(pins_nothing "^ebh: error: --pin sphere:10,10,10,1: the region pins no vertex of .*own_cm.msh \\(its bounding box: \\[0, 0, 0\\] \\.\\. \\[4, 3, 2\\] cm\\)"
  ${OWN} -o ${EBH_INIT}/pins_nothing.yaml --unit cm --pin sphere:10,10,10,1)
ebh_scene_init_failure(pins_everything "^ebh: error: --pin: the regions pin all 8 vertices of .*own_cm.msh: nothing could move"
  ${OWN} -o ${EBH_INIT}/pins_everything.yaml --unit cm --pin box:0,0,0,4,3,1 --pin box:0,0,1,4,3,2)
ebh_scene_init_failure(bad_pin "^ebh: error: --pin box:0,0,0,4,3: expected box:x0,y0,z0,x1,y1,z1 \\(6 numbers\\), got 5"
  ${OWN} -o ${EBH_INIT}/bad_pin.yaml --pin box:0,0,0,4,3)
ebh_scene_init_failure(bad_unit "^ebh: error: --unit: expected one of m, cm, mm, in, got 'inch'" ${OWN} -o ${EBH_INIT}/bad_unit.yaml --unit inch)
ebh_scene_init_failure(bad_tissue "^ebh: error: --tissue: expected liver, gallbladder, uterus or generic, got 'brain'"
  ${OWN} -o ${EBH_INIT}/bad_tissue.yaml --tissue brain)
ebh_scene_init_failure(not_a_mesh "^ebh: error: .*not_a_mesh.msh:1: not a Gmsh MSH file"
  ${EBH_INIT}/not_a_mesh.msh -o ${EBH_INIT}/not_a_mesh.yaml)
ebh_scene_init_failure(missing_mesh "^ebh: error: .*no_such.msh: cannot open" ${EBH_INIT}/no_such.msh -o ${EBH_INIT}/missing_mesh.yaml)
add_test(NAME cli.scene_init.over_the_mesh
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;init;${OWN};-o;${OWN}"
    "-DEXPECT=^ebh: error: .*own_cm.msh: the output would replace the mesh" -DKEEP=${OWN} -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# A scene written over another file that is not YAML (another scene's mesh): refused, kept.
file(COPY_FILE ${PROJECT_SOURCE_DIR}/scenarios/tube.msh ${EBH_INIT}/other.msh)
add_test(NAME cli.scene_init.over_another_mesh
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;init;${OWN};-o;${EBH_INIT}/other.msh"
    "-DEXPECT=^ebh: error: .*other.msh: a scene is a YAML file; name it .yaml" -DKEEP=${EBH_INIT}/other.msh -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene_init.write cli.scene_init.info cli.scene_init.synth cli.scene_init.replay
  cli.scene_init.over_the_mesh cli.scene_init.over_another_mesh PROPERTIES LABELS "cli;scene")

# ebh render (lib/render): a short tube replay with frames, rendered by `ebh replay --render` and
# indexed for ParaView (tube.xdmf); presets, --xdmf-only and bad input on that output.
set(EBH_RENDER_OUT ${PROJECT_BINARY_DIR}/cli_render)
file(MAKE_DIRECTORY ${EBH_RENDER_OUT})
set(EBH_EXPECT_ERROR ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# --render with --frames-hz 0 asks for frames and for none: refused before the replay.
add_test(NAME cli.render.frames_hz_0
  COMMAND ${CMAKE_COMMAND}
    "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_RENDER_OUT}/none.h5;--duration;0.1;--frames-hz;0;--render;${EBH_RENDER_OUT}/none"
    "-DEXPECT=^ebh: error: --render .*none: renders the mesh snapshots, and --frames-hz 0 asks for none"
    -DOUTPUT=${EBH_RENDER_OUT}/none.h5 -P ${EBH_EXPECT_ERROR})
set_tests_properties(cli.render.frames_hz_0 PROPERTIES LABELS "cli;render")
# --render naming the output (-o) would fail only after the replay wrote it: refused before.
add_test(NAME cli.render.folder_is_the_output
  COMMAND ${CMAKE_COMMAND}
    "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_RENDER_OUT}/same.h5;--duration;0.1;--render;${EBH_RENDER_OUT}/same.h5"
    "-DEXPECT=^ebh: error: --render .*same.h5: is the name of the replay output \\(-o\\)"
    -DOUTPUT=${EBH_RENDER_OUT}/same.h5 -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.render.folder_is_the_output PROPERTIES LABELS "cli;render")
# The frames replace every frame_*.png in their folder: a recording or an output named like one
# there is refused before the replay (it was replaced by a PNG, exit 0).
file(MAKE_DIRECTORY ${EBH_RENDER_OUT}/own_input)
configure_file(${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5 ${EBH_RENDER_OUT}/own_input/frame_00001.png COPYONLY)
add_test(NAME cli.render.frames_would_replace_the_recording
  COMMAND ${CMAKE_COMMAND}
    "-DCMD=${EBH_BIN};replay;tube;${EBH_RENDER_OUT}/own_input/frame_00001.png;-o;${EBH_RENDER_OUT}/own_input.h5;--duration;0.1;--render;${EBH_RENDER_OUT}/own_input"
    "-DEXPECT=^ebh: error: .*own_input: the frames would replace the recording .*own_input/frame_00001.png \\(frame_\\*.png files in the folder are the render's\\)"
    -DOUTPUT=${EBH_RENDER_OUT}/own_input.h5 -DKEEP=${EBH_RENDER_OUT}/own_input/frame_00001.png -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.render.frames_would_replace_the_output
  COMMAND ${CMAKE_COMMAND}
    "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_RENDER_OUT}/own_output/frame_00001.png;--duration;0.1;--render;${EBH_RENDER_OUT}/own_output"
    "-DEXPECT=^ebh: error: .*own_output: the frames would replace the replay output .*own_output/frame_00001.png"
    -DOUTPUT=${EBH_RENDER_OUT}/own_output/frame_00001.png -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.render.frames_would_replace_the_recording cli.render.frames_would_replace_the_output
  PROPERTIES LABELS "cli;render")
# Options that would do nothing where they are given are refused, not ignored.
add_test(NAME cli.render.xdmf_only_with_a_folder
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;--xdmf-only;-o;${EBH_RENDER_OUT}/unused"
    "-DEXPECT=^ebh: error: -o: --xdmf-only writes only the .xdmf beside the replay; leave -o out" -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.render.max_displacement_without_colours
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;-o;${EBH_RENDER_OUT}/unused;--max-displacement-mm;2"
    "-DEXPECT=^ebh: error: --max-displacement-mm: the top of the displacement colours; give --color-by displacement too"
    -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.render.xdmf_only_with_a_folder cli.render.max_displacement_without_colours PROPERTIES
  LABELS "cli;render")
if(EBH_HAVE_OSMESA)
  add_test(NAME cli.render.replay
    COMMAND ${CMAKE_COMMAND}
      "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_RENDER_OUT}/tube.h5;--duration;0.1;--frames-hz;20;--render;${EBH_RENDER_OUT}/frames;-q"
      "-DFILES=${EBH_RENDER_OUT}/frames/frame_00000.png;${EBH_RENDER_OUT}/frames/frame_00002.png;${EBH_RENDER_OUT}/tube.xdmf"
      -P ${CMAKE_CURRENT_SOURCE_DIR}/render/expect_files.cmake)
  set_tests_properties(cli.render.replay PROPERTIES FIXTURES_SETUP render_tube LABELS "cli;render")
  add_test(NAME cli.render.top_displacement
    COMMAND ${EBH_BIN} render ${EBH_RENDER_OUT}/tube.h5 -o ${EBH_RENDER_OUT}/top --camera top --size 160x120
      --color-by displacement)
  set_tests_properties(cli.render.top_displacement PROPERTIES PASS_REGULAR_EXPRESSION
    "top: 3 frames, 160x120, camera: preset top\n  tissue colour = displacement from rest: 0 mm"
    FIXTURES_REQUIRED render_tube LABELS "cli;render")
  # The colour range printed with %.3f gave a 300-digit number for 1e300 mm and 0.000 mm for 1e-9
  # mm: three significant digits, as the PNG's Comment states it.
  foreach(range 1e300 1e-9)
    add_test(NAME cli.render.colour_range_${range}
      COMMAND ${EBH_BIN} render ${EBH_RENDER_OUT}/tube.h5 -o ${EBH_RENDER_OUT}/range_${range} --size 32x24 --every 50
        --color-by displacement --max-displacement-mm ${range})
    set_tests_properties(cli.render.colour_range_${range} PROPERTIES FIXTURES_REQUIRED render_tube LABELS "cli;render")
  endforeach()
  set_tests_properties(cli.render.colour_range_1e300 PROPERTIES PASS_REGULAR_EXPRESSION
    "\\.\\. 1e\\+300 mm \\(red, top\\)\n")
  set_tests_properties(cli.render.colour_range_1e-9 PROPERTIES PASS_REGULAR_EXPRESSION
    "\\.\\. 1e-09 mm \\(red, top\\)\n")
  add_test(NAME cli.render.bad_camera
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;-o;${EBH_RENDER_OUT}/bad;--camera;fisheye"
      "-DEXPECT=^ebh: error: --camera: expected scene, top, front, side or iso, got 'fisheye'" -P ${EBH_EXPECT_ERROR})
  add_test(NAME cli.render.bad_size
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;-o;${EBH_RENDER_OUT}/bad;--size;big"
      "-DEXPECT=^ebh: error: --size: expected WIDTHxHEIGHT" -P ${EBH_EXPECT_ERROR})
  # a number past int was wrapped (4294967312 rendered 16 pixels)
  add_test(NAME cli.render.huge_size
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;-o;${EBH_RENDER_OUT}/bad;--size;4294967312x16"
      "-DEXPECT=^ebh: error: --size: expected WIDTHxHEIGHT in whole pixels .*got '4294967312x16'" -P ${EBH_EXPECT_ERROR})
  add_test(NAME cli.render.video_without_ffmpeg
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;-o;${EBH_RENDER_OUT}/video;--video;${EBH_RENDER_OUT}/v.mp4"
      "-DEXPECT=^ebh: error: --video .*v.mp4: ffmpeg was not found on the PATH" -P ${EBH_EXPECT_ERROR})
  set_tests_properties(cli.render.video_without_ffmpeg PROPERTIES ENVIRONMENT "PATH=${EBH_RENDER_OUT}/no_such_dir")
  # A frame that cannot be written (a file-size limit) is named by its final name, not the hidden
  # folder the frames are written into.
  add_test(NAME cli.render.write_fails
    COMMAND ${CMAKE_COMMAND}
      "-DCMD=sh;${PROJECT_BINARY_DIR}/cli_safety/limited.sh;30;${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;-o;${EBH_RENDER_OUT}/limited"
      "-DEXPECT=^ebh: error: [^\n]*/limited/frame_00000.png: cannot write the output: File too large; the previous frames are kept"
      -P ${EBH_EXPECT_ERROR})
  set_tests_properties(cli.render.bad_camera cli.render.bad_size cli.render.huge_size cli.render.video_without_ffmpeg
    cli.render.write_fails PROPERTIES FIXTURES_REQUIRED render_tube LABELS "cli;render")
  # The frames of `ebh replay --render` fail after the replay (a full disk): the previous output
  # stays too (it was replaced, and the previous frames then belonged to no output).
  add_test(NAME cli.render.fails_after_the_replay
    COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/render/render_fails_after_replay.sh ${EBH_BIN} ${EBH_RENDER_OUT}/full_disk)
  set_tests_properties(cli.render.fails_after_the_replay PROPERTIES SKIP_RETURN_CODE 77 LABELS "cli;render")
else()
  add_test(NAME cli.render.no_osmesa
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;-o;${EBH_RENDER_OUT}/frames"
      "-DEXPECT=^ebh: error: this build has no OSMesa: install libosmesa6-dev and reconfigure" -P ${EBH_EXPECT_ERROR})
  set_tests_properties(cli.render.no_osmesa PROPERTIES LABELS "cli;render")
endif()
# Without OSMesa too: the XDMF index, and a replay output without frames.
add_test(NAME cli.render.replay_no_frames
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_RENDER_OUT}/no_frames.h5 --duration 0.02 --frames-hz 0 -q)
set_tests_properties(cli.render.replay_no_frames PROPERTIES FIXTURES_SETUP render_no_frames LABELS "cli;render")
add_test(NAME cli.render.replay_writes_xdmf
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_RENDER_OUT}/xdmf.h5;--duration;0.05;--frames-hz;40;-q"
    "-DFILES=${EBH_RENDER_OUT}/xdmf.xdmf" -P ${CMAKE_CURRENT_SOURCE_DIR}/render/expect_files.cmake)
set_tests_properties(cli.render.replay_writes_xdmf PROPERTIES FIXTURES_SETUP render_xdmf LABELS "cli;render")
# The same output name replayed again without frames: the index of the frames it no longer has goes.
add_test(NAME cli.render.stale_index_written
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_RENDER_OUT}/stale.h5;--duration;0.05;--frames-hz;40;-q"
    "-DFILES=${EBH_RENDER_OUT}/stale.xdmf" -P ${CMAKE_CURRENT_SOURCE_DIR}/render/expect_files.cmake)
set_tests_properties(cli.render.stale_index_written PROPERTIES FIXTURES_SETUP stale_index LABELS "cli;render")
add_test(NAME cli.render.stale_index_removed
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_RENDER_OUT}/stale.h5;--duration;0.05;--frames-hz;0;-q"
    "-DFILES=${EBH_RENDER_OUT}/stale.h5" "-DGONE=${EBH_RENDER_OUT}/stale.xdmf"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/render/expect_files.cmake)
set_tests_properties(cli.render.stale_index_removed PROPERTIES FIXTURES_REQUIRED stale_index LABELS "cli;render")
add_test(NAME cli.render.xdmf_only COMMAND ${EBH_BIN} render ${EBH_RENDER_OUT}/xdmf.h5 --xdmf-only)
set_tests_properties(cli.render.xdmf_only PROPERTIES PASS_REGULAR_EXPRESSION "xdmf.xdmf"
  FIXTURES_REQUIRED render_xdmf LABELS "cli;render")
# Every dataset of a replay output (frames included) carries its unit (docs/FORMATS.md).
if(EBH_SYSTEM_PYTHON3 AND ebh_plot_deps EQUAL 0)
  add_test(NAME cli.replay.every_dataset_has_unit
    COMMAND ${EBH_SYSTEM_PYTHON3} ${CMAKE_CURRENT_SOURCE_DIR}/schedule/every_dataset_has_unit.py ${EBH_RENDER_OUT}/xdmf.h5)
  set_tests_properties(cli.replay.every_dataset_has_unit PROPERTIES PASS_REGULAR_EXPRESSION "datasets, each with a unit"
    FIXTURES_REQUIRED render_xdmf LABELS cli)
endif()
add_test(NAME cli.render.no_frames
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/no_frames.h5;--xdmf-only"
    "-DEXPECT=^ebh: error: .*no_frames.h5: /frames: no mesh snapshots in this file" -P ${EBH_EXPECT_ERROR})
set_tests_properties(cli.render.no_frames PROPERTIES FIXTURES_REQUIRED render_no_frames LABELS "cli;render")

# ebh replay (lib/schedule): a short replay writes its output; every bad input is one line on
# stderr, a non-zero exit and no output file (tests/io/expect_failure.cmake checks all three).
set(EBH_REPLAY_OUT ${PROJECT_BINARY_DIR}/cli_replay)
file(MAKE_DIRECTORY ${EBH_REPLAY_OUT})
add_test(NAME cli.replay.tube_short
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/tube.h5 --start 2.0 --duration 0.1 -q)
# The hook's tip catches the bore's rim at 2.08 s and the vertices let it through (vertex contact):
# the force falls from 0.57 to 0.06 N while the device presses on (its times given in the window
# and in the recording); with surface contact it holds.
add_test(NAME cli.replay.force_collapse COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/collapse.h5 -q
  --start 2.0 --duration 0.1)
set_tests_properties(cli.replay.force_collapse PROPERTIES PASS_REGULAR_EXPRESSION
  "collapse.h5: the force fell from 0.573 N \\(t = 0.079 s, 2.079 s into the recording\\) to 0.0611 N \\(t = 0.082 s, 2.082 s into the recording\\) while the tool stayed in contact and the device did not draw back: .*contact=surface")
add_test(NAME cli.replay.force_collapse_surface COMMAND ${EBH_BIN} replay tube tube_insert
  -o ${EBH_REPLAY_OUT}/collapse_surface.h5 -q --start 2.0 --duration 0.1 --set contact=surface)
set_tests_properties(cli.replay.force_collapse_surface PROPERTIES FAIL_REGULAR_EXPRESSION "fell from")
# A window that starts in the middle of a press: the tissue begins at rest around the hook (a
# tenth of the force), said before the replay with the last time the hook was clear of it; the
# gate's window of the press starts before it and is not.
add_test(NAME cli.replay.start_inside_a_press COMMAND ${EBH_BIN} replay cholecystectomy_hook cholecystectomy_press
  -o ${EBH_REPLAY_OUT}/inside_press.h5 -q --start 1.5 --duration 0.01)
set_tests_properties(cli.replay.start_inside_a_press PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "cholecystectomy_press.h5: --start 1.5: the replay starts with the tool's tip 1 mm or more inside the tissue \\(at the recording's t = 1.5 s\\), which begins at rest around it.*; start at or before 1.16 s into the recording, where the tool was clear of it")
add_test(NAME cli.replay.start_before_a_press COMMAND ${EBH_BIN} replay cholecystectomy_hook cholecystectomy_press
  -o ${EBH_REPLAY_OUT}/before_press.h5 -q --start 0.9 --duration 0.01)
set_tests_properties(cli.replay.start_before_a_press PROPERTIES LABELS cli FAIL_REGULAR_EXPRESSION "inside the tissue")
# The hook held still in the tube for 18 s: its force falls by more than 20%, which the replay says
# is the coupled meshes settling, not the tissue (docs/MODEL.md, "Held loads").
add_test(NAME cli.replay.held_force_falls_synth
  COMMAND ${EBH_BIN} synth ${EBH_IO_DATA}/tube_hold.yaml -o ${EBH_REPLAY_OUT}/tube_hold.h5)
set_tests_properties(cli.replay.held_force_falls_synth PROPERTIES FIXTURES_SETUP tube_hold LABELS cli)
add_test(NAME cli.replay.held_force_falls
  COMMAND ${EBH_BIN} replay tube ${EBH_REPLAY_OUT}/tube_hold.h5 -o ${EBH_REPLAY_OUT}/tube_hold_out.h5 -q)
set_tests_properties(cli.replay.held_force_falls PROPERTIES FIXTURES_REQUIRED tube_hold LABELS cli PASS_REGULAR_EXPRESSION
  "tube_hold_out.h5: the force fell from 0\\.0[89][0-9]* to 0\\.0[5-7][0-9]* N \\([0-9]+%\\) over the 18\\.[0-9]+ s the device held still on the tissue \\(from t = 1\\.[0-9]+ s\\): not the tissue relaxing")
# A physical rate below the paper's 60-100 Hz: said, naming the option or the override.
add_test(NAME cli.replay.slow_physical_rate COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/slow.h5 -q
  --duration 0.2 --physical-hz 10)
set_tests_properties(cli.replay.slow_physical_rate PROPERTIES PASS_REGULAR_EXPRESSION
  "warning: --physical-hz 10 Hz: the physical mesh answers the virtual mesh 10 times a second \\(the paper: 60-100\\)")
add_test(NAME cli.replay.slowish_physical_rate COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/slowish.h5
  -q --duration 0.2 --set time.physical_hz=25)
set_tests_properties(cli.replay.slowish_physical_rate PROPERTIES PASS_REGULAR_EXPRESSION
  "warning: --set 'time.physical_hz=25': time.physical_hz 25 Hz: .*the force of a press rises with its speed")
add_test(NAME cli.replay.summary
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/tube_summary.h5 --duration 0.05 --mode lockstep)
set_tests_properties(cli.replay.summary PROPERTIES
  PASS_REGULAR_EXPRESSION "lockstep mode, 51 ticks, 6 physical steps.*real time.*peak force")
function(ebh_replay_failure name expect)
  add_test(NAME cli.replay.${name}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;${ARGN};-o;${EBH_REPLAY_OUT}/${name}.h5;-q"
      "-DEXPECT=${expect}" -DOUTPUT=${EBH_REPLAY_OUT}/${name}.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
endfunction()
# A device faster than the virtual tool's Newton steps reach in a tick: at 10 Hz (20 mm/s), and
# with tool.max_step given in metres into a mm scene (2 mm/s; the force limit with nothing touched).
add_test(NAME cli.replay.tool_outpaced_at_a_low_rate
  COMMAND ${EBH_BIN} replay tube tube_insert --start 2 --duration 1 --haptic-hz 10 --physical-hz 10
    -o ${EBH_REPLAY_OUT}/outpaced.h5 -q)
set_tests_properties(cli.replay.tool_outpaced_at_a_low_rate PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "warning: .*outpaced.h5: the device moved farther in a tick than the virtual tool can follow in [0-9]+ of 11 ticks \\(up to [0-9.]+ mm, against 2 mm a tick: .* 20 mm/s at 10 Hz\\)")
add_test(NAME cli.replay.max_step_in_the_wrong_unit
  COMMAND ${EBH_BIN} replay tube tube_insert --duration 2 --set tool.max_step=0.0005 -o ${EBH_REPLAY_OUT}/max_step_m.h5 -q)
set_tests_properties(cli.replay.max_step_in_the_wrong_unit PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "against 0.002 mm a tick.*[1-9][0-9]* ticks rendered the force limit \\(3.3 N\\) with no contact: the coupling's stretch, not tissue; raise tool.max_step \\(tool.unit mm\\)")
# The same for turns: a brisk wrist roll (90 degrees in 0.15 s) against one Newton call a tick
# (0.5 degrees), with a torque limit the lag reaches in free air; the scene's four calls follow it
# (and a synthesised path, held still but for its tremor, is not doubted for its unit).
add_test(NAME cli.replay.gap_roll_synth
  COMMAND ${EBH_BIN} synth ${EBH_IO_DATA}/gap_roll.yaml -o ${EBH_REPLAY_OUT}/gap_roll.h5)
set_tests_properties(cli.replay.gap_roll_synth PROPERTIES FIXTURES_SETUP gap_roll LABELS cli)
add_test(NAME cli.replay.tool_outturned
  COMMAND ${EBH_BIN} replay gap ${EBH_REPLAY_OUT}/gap_roll.h5 -o ${EBH_REPLAY_OUT}/outturned.h5 -q
    --set tool.newton_calls=1 --set tool.torque_limit=0.01)
set_tests_properties(cli.replay.tool_outturned PROPERTIES FIXTURES_REQUIRED gap_roll LABELS cli PASS_REGULAR_EXPRESSION
  "warning: .*outturned.h5: the device turned farther in a tick than the virtual tool can follow in [0-9]+ of 1001 ticks \\(up to 1.[0-9]+ degrees, against 0.5 degrees a tick: .* 8.73 rad/s at 1000 Hz\\), so the tool lags it and the torque grows with the lag \\(stiffness.k_vct 0.3 N m a radian\\); [1-9][0-9]* of 1001 ticks rendered the torque limit \\(0.01 N m\\) with no contact: .*; raise tool.max_step_rotation_deg or the haptic rate\n")
add_test(NAME cli.replay.tool_follows_the_roll
  COMMAND ${EBH_BIN} replay gap ${EBH_REPLAY_OUT}/gap_roll.h5 -o ${EBH_REPLAY_OUT}/roll_followed.h5 -q)
set_tests_properties(cli.replay.tool_follows_the_roll PROPERTIES FIXTURES_REQUIRED gap_roll LABELS cli
  FAIL_REGULAR_EXPRESSION "turned farther|torque limit|path spans")
# Settling under gravity that stops at its cap with the mesh still moving (the warning says so) is
# not "the static equilibrium" in the summary.
add_test(NAME cli.replay.settle_capped
  COMMAND ${EBH_BIN} replay cholecystectomy_hook cholecystectomy_press --duration 0.01 --set gravity=[0,0,-9.81]
    -o ${EBH_REPLAY_OUT}/settle_capped.h5)
set_tests_properties(cli.replay.settle_capped PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "  started after 25 static steps under gravity, before the mesh had settled \\(the warning above\\)\n"
  FAIL_REGULAR_EXPRESSION "static equilibrium")
# A scene asking for frames at a haptic rate below their default 30 a second takes one a tick.
add_test(NAME cli.replay.frames_default_at_a_low_rate
  COMMAND ${EBH_BIN} replay gap gap_insert --start 3 --duration 0.5 --haptic-hz 10 --physical-hz 10
    --set stages.frames=true -o ${EBH_REPLAY_OUT}/frames_10hz.h5)
set_tests_properties(cli.replay.frames_default_at_a_low_rate PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION "6 ticks, 6 physical steps")
# A recording replayed on a scene other than the one it names.
add_test(NAME cli.replay.recording_of_another_scene
  COMMAND ${EBH_BIN} replay gap tube_insert --duration 0.05 -o ${EBH_REPLAY_OUT}/other_scene.h5 -q)
set_tests_properties(cli.replay.recording_of_another_scene PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "warning: .*tube_insert.h5: recorded for the scene 'tube' \\(its scene attribute\\) and replayed on 'gap'")
ebh_replay_failure(missing_recording "no such recording" tube no_such_recording)
ebh_replay_failure(missing_scene "no_such_scene" no_such_scene tube_insert)
ebh_replay_failure(not_hdf5 "tube.yaml" tube ${PROJECT_SOURCE_DIR}/scenarios/tube.yaml)
ebh_replay_failure(unknown_override_key "stiffness.k_bogus" tube tube_insert --set stiffness.k_bogus=1)
ebh_replay_failure(bad_override_value "stiffness.k_con" tube tube_insert --set stiffness.k_con=-5)
ebh_replay_failure(negative_active_region "solver.active_region" tube tube_insert --set solver.active_region=-0.01)
ebh_replay_failure(bad_mode "--mode: expected async, lockstep or realtime" tube tube_insert --mode fast)
ebh_replay_failure(bad_rates "^ebh: error: --physical-hz 300: the haptic rate over the physical rate must be a whole number >= 1 \\(ticks per physical step\\), got 1000 / 300 = 3.33333"
  tube tube_insert --haptic-hz 1000 --physical-hz 300)
ebh_replay_failure(bad_rate_against_scene "^ebh: error: --physical-hz 300: .* got 1000 \\(the scene's time.haptic_hz\\) / 300"
  tube tube_insert --physical-hz 300)
ebh_replay_failure(physical_above_haptic "^ebh: error: --physical-hz 1000.0000001: the physical rate is above the haptic rate \\(1000.0000001 Hz > 1000 Hz, the scene's time.haptic_hz\\)"
  tube tube_insert --physical-hz 1000.0000001)
ebh_replay_failure(tiny_rates "^ebh: error: --haptic-hz: expected a finite number in \\[10, 100000\\] Hz, got '1e-300'"
  tube tube_insert --haptic-hz 1e-300 --physical-hz 1e-300)
ebh_replay_failure(tiny_physical_rate "^ebh: error: --physical-hz: expected a finite number in \\[1, 100000\\] Hz, got '1e-300'"
  tube tube_insert --physical-hz 1e-300)
ebh_replay_failure(tiny_physical_rate_set "^ebh: error: --set 'time.physical_hz=0.5': key 'time.physical_hz': expected a number in \\[1, 100000\\]"
  tube tube_insert --set time.physical_hz=0.5)
ebh_replay_failure(bad_start "--start" tube tube_insert --start 99)
ebh_replay_failure(hex_duration "^ebh: error: --duration: expected a finite number > 0, got '0x10'" tube tube_insert --duration 0x10)
# A window under one haptic tick replays a single tick with no force step (it wrote one and exited
# 0): refused naming the option and the tick, at the rate --set gives, or --start where the
# recording's end cuts the window under a tick.
ebh_replay_failure(duration_under_a_tick "^ebh: error: --duration 1e-320: shorter than one haptic tick \\(0.001 s at 1000 Hz\\), which replays a single tick with no force step to measure: expected at least 0.001 s"
  tube tube_insert --duration 1e-320)
ebh_replay_failure(duration_under_a_set_tick "^ebh: error: --duration 0.005: shorter than one haptic tick \\(0.01 s at 100 Hz\\)"
  tube tube_insert --duration 0.005 --set time.haptic_hz=100)
ebh_replay_failure(start_leaves_under_a_tick "^ebh: error: --start 9.9995: leaves 0.0005 s of the recording .*tube_insert.h5 \\(10 s long\\), less than one haptic tick \\(0.001 s at 1000 Hz\\).*: start at least 0.001 s before its end"
  tube tube_insert --start 9.9995)
ebh_replay_failure(bad_backend "--backend" tube tube_insert --backend opencl)
# An error an override causes names the override, not the scene file.
ebh_replay_failure(set_too_deep "^ebh: error: --set 'a.b.c.d=1': key 'a': unknown key \\(known: name, "
  tube tube_insert --set a.b.c.d=1)
ebh_replay_failure(set_rates "^ebh: error: --set 'time.physical_hz=70': key 'time.physical_hz': haptic_hz / physical_hz must be a whole number >= 1, got 1000 / 70 = 14.2857"
  tube tube_insert --set time.haptic_hz=1000 --set time.physical_hz=70)
ebh_replay_failure(set_twice "--set 'stiffness.k_con=900': key 'stiffness.k_con' given twice \\(also --set 'stiffness.k_con=800'\\)"
  tube tube_insert --set stiffness.k_con=800 --set stiffness.k_con=900)
ebh_replay_failure(rate_option_and_set "^ebh: error: --haptic-hz 2000: and --set 'time.haptic_hz=500' give one value twice"
  tube tube_insert --haptic-hz 2000 --set time.haptic_hz=500)
# A map value sets each of its keys: the same checks hold for them.
ebh_replay_failure(rate_option_and_set_map "^ebh: error: --haptic-hz 2000: and --set 'time={haptic_hz: 500}' give one value twice"
  tube tube_insert --haptic-hz 2000 "--set" "time={haptic_hz: 500}")
ebh_replay_failure(set_twice_in_map "--set 'stiffness={k_con: 900}': key 'stiffness.k_con' given twice \\(also --set 'stiffness.k_con=800'\\)"
  tube tube_insert --set stiffness.k_con=800 "--set" "stiffness={k_con: 900}")
# An empty option value is refused, naming the option: it would read as the option's default
# (`--level ''` as 0, `--recording ''` as not given). {} is the empty argument (tests/empty_arg.sh).
set(EBH_EMPTY_ARG sh ${CMAKE_CURRENT_SOURCE_DIR}/empty_arg.sh ${EBH_BIN})
foreach(empty "level|scene;refine;tube;--level;{};-o;${EBH_REPLAY_OUT}/empty_level.yaml"
              "recording|bench;sizes;--recording;{};--levels;0;--plot;${EBH_REPLAY_OUT}/empty_recording.png"
              "output|replay;tube;tube_insert;-o;{}"
              "set|replay;tube;tube_insert;-o;${EBH_REPLAY_OUT}/empty_set.h5;--set;{}"
              "scene|replay;{};tube_insert;-o;${EBH_REPLAY_OUT}/empty_scene.h5"
              "transform|import;${CMAKE_CURRENT_SOURCE_DIR}/data/io/sample.csv;-o;${EBH_REPLAY_OUT}/empty_transform.h5;--transform;{}"
              "recording|validate;stability;--recording;{}")
  string(REPLACE "|" ";" empty "${empty}")
  list(POP_FRONT empty option)
  list(GET empty 0 command)
  add_test(NAME cli.empty_value.${command}_${option}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_EMPTY_ARG};${empty}" "-DEXPECT=^ebh: error: -?-?${option}: expected a value, got an empty one"
      -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.empty_value.${command}_${option} PROPERTIES LABELS cli)
endforeach()
# A realtime replay whose ticks cannot keep up (100 kHz: 10 us a tick) says it fell behind.
add_test(NAME cli.replay.realtime_behind
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/behind.h5 --start 4 --duration 0.005 --mode realtime
    --haptic-hz 100000 --physical-hz 10000 -q)
set_tests_properties(cli.replay.realtime_behind PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "warning: .*behind.h5: the realtime replay fell behind the clock \\(0\\.[0-9]+x real time")
# A window past the recording's end is cut there, and the replay says so.
add_test(NAME cli.replay.duration_past_the_end
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/past_end.h5 --start 9.9 --duration 100 -q)
set_tests_properties(cli.replay.duration_past_the_end PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "warning: .*tube_insert.h5: the recording ends 0.1 s after --start; replaying those, not --duration's 100 s")
set_tests_properties(cli.replay.duration_past_the_end PROPERTIES FIXTURES_SETUP past_end)
# ... and the output's `duration` attribute is what was replayed, not the 100 s asked for.
if(EBH_SYSTEM_PYTHON3 AND ebh_plot_deps EQUAL 0)
  add_test(NAME cli.replay.duration_past_the_end_attribute
    COMMAND ${EBH_SYSTEM_PYTHON3} -c "import h5py, sys; print('duration', h5py.File(sys.argv[1], 'r').attrs['duration'])"
      ${EBH_REPLAY_OUT}/past_end.h5)
  set_tests_properties(cli.replay.duration_past_the_end_attribute PROPERTIES FIXTURES_REQUIRED past_end LABELS cli
    PASS_REGULAR_EXPRESSION "duration 0\\.(1|0999)")
endif()
# ebh replay --batch FILE: each bad line is refused with FILE:LINE before any replay runs (and
# before the CUDA backend is asked for, so these run on machines without a GPU too).
function(ebh_batch_failure name expect content)
  file(WRITE ${EBH_REPLAY_OUT}/batch_${name}.txt "${content}")
  add_test(NAME cli.replay.batch_${name}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;--batch;${EBH_REPLAY_OUT}/batch_${name}.txt;-q"
      "-DEXPECT=${expect}" -DOUTPUT=${EBH_REPLAY_OUT}/batch_${name}_out.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.replay.batch_${name} PROPERTIES LABELS cli)
endfunction()
file(MAKE_DIRECTORY ${EBH_REPLAY_OUT})
ebh_batch_failure(empty "batch_empty.txt: no replays" "# nothing\n\n")
# A batch file saved with a UTF-8 byte-order mark (Windows editors): its first line is read as any other.
string(ASCII 239 187 191 EBH_UTF8_BOM)
ebh_batch_failure(byte_order_mark "batch_byte_order_mark.txt:1: no_such_recording: no such recording"
  "${EBH_UTF8_BOM}tube no_such_recording -o ${EBH_REPLAY_OUT}/batch_byte_order_mark_out.h5\n")
ebh_batch_failure(unknown_option "batch_unknown_option.txt:2: .*--bogus"
  "# a comment\ntube tube_insert -o ${EBH_REPLAY_OUT}/batch_unknown_option_out.h5 --bogus 3\n")
ebh_batch_failure(no_output "batch_no_output.txt:1: expected SCENE RECORDING -o OUT.h5" "tube tube_insert\n")
ebh_batch_failure(lockstep "batch_lockstep.txt:1: --mode lockstep: a batch runs in async mode"
  "tube tube_insert -o ${EBH_REPLAY_OUT}/batch_lockstep_out.h5 --mode lockstep\n")
ebh_batch_failure(cpu "batch_cpu.txt:1: --backend cpu: a batch runs on the CUDA backend"
  "tube tube_insert -o ${EBH_REPLAY_OUT}/batch_cpu_out.h5 --backend cpu\n")
# --backend cpu beside --batch (not on a line) is named as such, not as a missing GPU.
add_test(NAME cli.replay.batch_top_cpu
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;--batch;${EBH_REPLAY_OUT}/batch_empty.txt;--backend;cpu"
    "-DEXPECT=^ebh: error: --backend cpu: --batch runs its replays on the CUDA backend" -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.replay.batch_top_cpu PROPERTIES LABELS cli)
ebh_batch_failure(frames "batch_frames.txt:1: a batch writes no mesh frames"
  "tube tube_insert -o ${EBH_REPLAY_OUT}/batch_frames_out.h5 --frames-hz 30\n")
ebh_batch_failure(missing_recording "batch_missing_recording.txt:2: .*no_such_recording"
  "tube tube_insert -o ${EBH_REPLAY_OUT}/batch_missing_recording_out.h5\ntube no_such_recording -o ${EBH_REPLAY_OUT}/x.h5\n")
ebh_batch_failure(same_output "is both .*batch_same_output.txt:1's replay output and .*batch_same_output.txt:2's replay output"
  "tube tube_insert -o ${EBH_REPLAY_OUT}/batch_same_output_out.h5\ntube tube_grasp -o ${EBH_REPLAY_OUT}/batch_same_output_out.h5\n")
ebh_batch_failure(output_is_input "would replace .*batch_output_is_input.txt:1's recording .*tube_insert.h5, an input"
  "tube tube_insert -o ${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5\n")
ebh_batch_failure(set_twice "batch_set_twice.txt:1: --set 'solver.virtual_iterations=2': key 'solver.virtual_iterations' given twice"
  "tube tube_insert -o ${EBH_REPLAY_OUT}/batch_set_twice_out.h5 --set solver.virtual_iterations=1 --set solver.virtual_iterations=2\n")
ebh_batch_failure(output_is_batch_file "would replace the batch file .*batch_output_is_batch_file.txt, an input"
  "tube tube_insert -o ${EBH_REPLAY_OUT}/batch_output_is_batch_file.txt\n")
add_test(NAME cli.replay.batch_missing_file
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;--batch;${EBH_REPLAY_OUT}/no_such_batch.txt"
    "-DEXPECT=no_such_batch.txt: cannot open" -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.batch_is_a_recording
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;--batch;${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5"
    "-DEXPECT=^ebh: error: .*tube_insert.h5: an HDF5 file \\(a recording or a replay output\\), not a batch list" -DSTATUS=1
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.batch_with_scene
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;--batch;${EBH_REPLAY_OUT}/batch_cpu.txt"
    "-DEXPECT=--batch .*: give each replay's scene" -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.no_arguments
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube"
    "-DEXPECT=expected SCENE RECORDING -o OUT.h5" -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.at_once_without_batch
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_REPLAY_OUT}/at_once.h5;--at-once;3"
    "-DEXPECT=--at-once requires --batch" -DOUTPUT=${EBH_REPLAY_OUT}/at_once.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.replay.batch_missing_file cli.replay.batch_is_a_recording cli.replay.batch_with_scene cli.replay.no_arguments
  cli.replay.at_once_without_batch PROPERTIES LABELS cli)
# Virtual edges stiffer than the coupling to the physical mesh: the async loop can go unstable (the
# warning names the override that gave the value, as every warning about a value does).
add_test(NAME cli.replay.k_s_over_k_svc_warns
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_REPLAY_OUT}/k_s.h5 --set stiffness.k_s=100 --duration 0.01 -q)
set_tests_properties(cli.replay.k_s_over_k_svc_warns PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "warning: --set 'stiffness.k_s=100': stiffness.k_s is 2 times k_svc: in async mode")
add_test(NAME cli.replay.k_s_under_k_svc_quiet
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_REPLAY_OUT}/k_s_ok.h5 --set stiffness.k_s=50 --duration 0.01 -q)
set_tests_properties(cli.replay.k_s_under_k_svc_quiet PROPERTIES LABELS cli FAIL_REGULAR_EXPRESSION "times k_svc")
# The k_s warning recommends lockstep: a lockstep replay leaves it out; a denormal k_svc gives no "inf times".
add_test(NAME cli.replay.k_s_over_k_svc_lockstep_quiet
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_REPLAY_OUT}/k_s_lockstep.h5 --set stiffness.k_s=100 --mode lockstep
    --duration 0.1 -q)
set_tests_properties(cli.replay.k_s_over_k_svc_lockstep_quiet PROPERTIES LABELS cli FAIL_REGULAR_EXPRESSION "times k_svc")
add_test(NAME cli.replay.k_s_over_denormal_k_svc
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_REPLAY_OUT}/k_svc_tiny.h5 --set stiffness.k_svc=5e-324 --duration 0.1 -q)
set_tests_properties(cli.replay.k_s_over_denormal_k_svc PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "--set 'stiffness.k_svc=5e-324': stiffness.k_vol x the virtual mesh's mean edge [^\n]* is more than a million times stiffness.k_svc.*stiffness.k_s is more than a million times k_svc"
  FAIL_REGULAR_EXPRESSION "inf times")
# With surface contact, a Newton step longer than the tool's thinnest part can carry it through.
add_test(NAME cli.replay.surface_step_beyond_thinnest_part_warns
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/surface_step.h5 --set contact=surface
    --set tool.max_step=2 --duration 0.01 -q)
set_tests_properties(cli.replay.surface_step_beyond_thinnest_part_warns PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "warning: --set 'tool.max_step=2': tool.max_step = 2 mm is above the tool's thinnest part \\(1 mm\\): with contact: surface")
# The surface stiffness floor follows the force limit: a limit of 1000 N makes a contact stiffer
# than any device renders, against which the virtual mesh's iterations do not settle.
add_test(NAME cli.replay.surface_floor_beyond_devices_warns
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/surface_floor.h5 --set contact=surface
    --set tool.force_limit=1000 --duration 0.01 -q)
set_tests_properties(cli.replay.surface_floor_beyond_devices_warns PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "warning: --set 'tool.force_limit=1000': with contact: surface the stiffness floor F_limit / \\(1.5 x the tool's thinnest part\\) raises k_con to 6.67e\\+05 N/m")
# Movement thresholds far larger than the mesh hold it still under every touch: warned at load.
add_test(NAME cli.replay.sleep_beyond_mesh_warns
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/sleep_big.h5 --set solver.sleep=1000 --duration 0.1 -q)
set_tests_properties(cli.replay.sleep_beyond_mesh_warns PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "warning: --set 'solver.sleep=1000': solver.sleep = 1000 mm is over 0.1% of the physical mesh's bounding-box diagonal")
add_test(NAME cli.replay.physical_region_beyond_mesh_warns
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/region_big.h5 --set solver.physical_region=1e9 --duration 0.1 -q)
set_tests_properties(cli.replay.physical_region_beyond_mesh_warns PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "warning: .*solver.physical_region = 1e\\+09 mm is over 0.1%")
add_test(NAME cli.replay.small_regions_quiet
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/region_small.h5 --set solver.physical_region=0.03
    --set solver.active_region=0.03 --set solver.sleep=0.03 --duration 0.1 -q)
set_tests_properties(cli.replay.small_regions_quiet PROPERTIES LABELS cli FAIL_REGULAR_EXPRESSION "diagonal")
# An async window shorter than one physical period: no physical step's result reaches the haptic side.
add_test(NAME cli.replay.no_physical_result_warns
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/no_physical.h5 --physical-hz 1 --duration 0.3 -q)
set_tests_properties(cli.replay.no_physical_result_warns PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "warning: .*no_physical.h5: the haptic side never saw a physical result: the window's 301 ticks")
add_test(NAME cli.replay.physical_result_seen_quiet
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/physical_seen.h5 --duration 0.011 -q)
set_tests_properties(cli.replay.physical_result_seen_quiet PROPERTIES LABELS cli FAIL_REGULAR_EXPRESSION "never saw")
# A recording in mm imported as metres lands a thousand scene sizes away: a unit mistake.
add_test(NAME cli.replay.make_unit_mistake
  COMMAND ${EBH_BIN} import ${EBH_IO_DATA}/sample_openhaptics.txt -o ${EBH_REPLAY_OUT}/unit_mistake_rec.h5 --scene tube --unit m)
set_tests_properties(cli.replay.make_unit_mistake PROPERTIES FIXTURES_SETUP unit_mistake)
ebh_replay_failure(unit_mistake "unit mistake" tube ${EBH_REPLAY_OUT}/unit_mistake_rec.h5)
set_tests_properties(cli.replay.unit_mistake PROPERTIES FIXTURES_REQUIRED unit_mistake)
# A replay where the tool never touches the tissue says so (stderr); one with contact does not.
add_test(NAME cli.replay.no_contact
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/no_contact.h5 --duration 0.05 -q)
set_tests_properties(cli.replay.no_contact PROPERTIES FIXTURES_SETUP no_contact
  PASS_REGULAR_EXPRESSION "ebh: warning: .*no_contact.h5: the tool never touched the tissue \\(no tick with contacts > 0\\)")
add_test(NAME cli.replay.contact_no_warning
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_REPLAY_OUT}/contact.h5 --start 2.8 --duration 0.05 -q)
set_tests_properties(cli.replay.contact_no_warning PROPERTIES FAIL_REGULAR_EXPRESSION "touched the tissue")
# No contact, and no tip inside the tissue as the replay found it: the soft block settled under its
# weight below the rest shape the tip reaches into (the warning had said it passed between vertices).
add_test(NAME cli.replay.make_sag_press
  COMMAND ${EBH_BIN} synth ${EBH_IO_DATA}/gap_sag_press.yaml -o ${EBH_REPLAY_OUT}/sag_press_rec.h5)
set_tests_properties(cli.replay.make_sag_press PROPERTIES LABELS cli FIXTURES_SETUP sag_press)
add_test(NAME cli.replay.no_contact_on_the_settled_mesh
  COMMAND ${EBH_BIN} replay gap ${EBH_REPLAY_OUT}/sag_press_rec.h5 -o ${EBH_REPLAY_OUT}/sag_press.h5 --set stiffness.k_vol=500 -q)
set_tests_properties(cli.replay.no_contact_on_the_settled_mesh PROPERTIES LABELS cli FIXTURES_REQUIRED sag_press
  PASS_REGULAR_EXPRESSION "sag_press.h5: the tool never touched the tissue \\(no tick with contacts > 0\\)\n"
  FAIL_REGULAR_EXPRESSION "tip went inside")
# No contact although the tip went into the tissue, with surface contact on the physical mesh's own
# boundary: the virtual mesh is where the tissue is, so the cause is not mesh.virtual (here a
# virtual tool all but uncoupled from the device).
add_test(NAME cli.replay.no_contact_on_the_boundary
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_REPLAY_OUT}/uncoupled.h5 --start 2 --duration 0.3
    --set contact=surface --set stiffness.k_vcs=1e-12 -q)
set_tests_properties(cli.replay.no_contact_on_the_boundary PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "uncoupled.h5: the tool never touched the tissue .*, yet the tool's tip went inside the physical mesh where the replay started .*: the tissue moved away from it .*, or the virtual tool did not follow the device \\(stiffness.k_vcs, stiffness.k_con\\)"
  FAIL_REGULAR_EXPRESSION "mesh.virtual")
add_test(NAME cli.metrics.no_contact_table COMMAND ${EBH_BIN} metrics ${EBH_REPLAY_OUT}/no_contact.h5)
set_tests_properties(cli.metrics.no_contact_table PROPERTIES FIXTURES_REQUIRED no_contact
  PASS_REGULAR_EXPRESSION "\n  warning: the tool never touched the tissue")
add_test(NAME cli.metrics.no_contact_json COMMAND ${EBH_BIN} metrics ${EBH_REPLAY_OUT}/no_contact.h5 --json)
set_tests_properties(cli.metrics.no_contact_json PROPERTIES FIXTURES_REQUIRED no_contact
  PASS_REGULAR_EXPRESSION "\"contact_fraction\": 0,.*\"contact_warning\": \"the tool never touched the tissue")
# /physical/inverted: counted in a new replay's output (0 tets here), null in a file written without it.
add_test(NAME cli.metrics.inverted_counted COMMAND ${EBH_BIN} metrics ${EBH_REPLAY_OUT}/no_contact.h5 --json)
set_tests_properties(cli.metrics.inverted_counted PROPERTIES FIXTURES_REQUIRED no_contact LABELS cli
  PASS_REGULAR_EXPRESSION "\"physical_inverted_max\": 0[,\n]")
add_test(NAME cli.metrics.inverted_absent COMMAND ${EBH_BIN} metrics ${EBH_METRICS_DATA}/press.h5 --json)
set_tests_properties(cli.metrics.inverted_absent PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "\"physical_inverted_max\": null")
add_test(NAME cli.metrics.contact_json COMMAND ${EBH_BIN} metrics ${EBH_METRICS_DATA}/press.h5 --json)
set_tests_properties(cli.metrics.contact_json PROPERTIES PASS_REGULAR_EXPRESSION "\"contact_warning\": null")
set_property(TEST cli.replay.no_contact cli.replay.contact_no_warning cli.metrics.no_contact_table
  cli.metrics.no_contact_json cli.metrics.contact_json APPEND PROPERTY LABELS cli)
set_property(TEST cli.replay.tube_short cli.replay.summary cli.replay.make_unit_mistake cli.replay.missing_recording
  cli.replay.missing_scene cli.replay.not_hdf5 cli.replay.unknown_override_key cli.replay.bad_override_value
  cli.replay.bad_mode cli.replay.bad_rates cli.replay.bad_rate_against_scene cli.replay.tiny_rates
  cli.replay.tiny_physical_rate cli.replay.tiny_physical_rate_set cli.replay.bad_start cli.replay.bad_backend cli.replay.unit_mistake
  PROPERTY LABELS cli)

# ebh validate (lib/validate) and ebh table1.
add_test(NAME cli.validate.list COMMAND ${EBH_BIN} validate --list)
set_tests_properties(cli.validate.list PROPERTIES PASS_REGULAR_EXPRESSION "column.*contact.*coupling.*convergence.*hertz.*stability" LABELS cli)
add_test(NAME cli.validate.list_json COMMAND ${EBH_BIN} validate --list --json)
set_tests_properties(cli.validate.list_json PROPERTIES
  PASS_REGULAR_EXPRESSION "^\\[\n  {\n    \"name\": \"column\",\n    \"description\": " LABELS cli)
# Each method exactly K iterations: its error falls with K, and Chebyshev beats Jacobi (a few s).
add_test(NAME cli.validate.convergence COMMAND ${EBH_BIN} validate convergence)
set_tests_properties(cli.validate.convergence PROPERTIES LABELS cli)
# --recording is checked before any validation runs: a recording that does not resolve or read, or
# one given to a validation that replays none, is refused.
foreach(v "column;nope;--recording: nope: no such recording" "all;${PROJECT_SOURCE_DIR}/scenarios/tube.yaml;--recording: .*tube.yaml: not an HDF5 file"
          "column;tube_insert;--recording tube_insert: the column validation replays no recording \\(--recording is for coupling and stability\\)")
  list(GET v 0 name)
  list(GET v 1 recording)
  list(GET v 2 expect)
  get_filename_component(rname ${recording} NAME_WE)
  add_test(NAME cli.validate.recording_${name}_${rname}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};validate;${name};--recording;${recording}" "-DEXPECT=^ebh: error: ${expect}"
      -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.validate.recording_${name}_${rname} PROPERTIES LABELS "cli;validate")
endforeach()
# --full is refused by a validation that has no long form (it would run its one form and pass).
foreach(name column hertz)
  add_test(NAME cli.validate.full_${name}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};validate;${name};--full"
      "-DEXPECT=^ebh: error: --full: the ${name} validation has no full form \\(--full is for contact, coupling and stability\\)"
      -DSTATUS=1 -DNO_STDOUT=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.validate.full_${name} PROPERTIES LABELS "cli;validate")
endforeach()
# --backend cuda is refused by a validation that runs on the CPU only (it ran there without a word),
# before the device is looked for.
add_test(NAME cli.validate.backend_column
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};validate;column;--backend;cuda"
    "-DEXPECT=^ebh: error: --backend cuda: the column validation runs on the CPU only \\(--backend is for coupling and stability\\)"
    -DSTATUS=1 -DNO_STDOUT=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.validate.backend_column PROPERTIES LABELS "cli;validate")
add_test(NAME cli.validate.column_json COMMAND ${EBH_BIN} validate column --json)
# keys with their unit, as metrics --json: N and Pa, not n (a count) and pa
set_tests_properties(cli.validate.column_json PROPERTIES
  PASS_REGULAR_EXPRESSION "\"passed\": true.*\"k_vol_Pa\": 3000,.*\"reaction_N\": 0\\.006,\n +\"expected_N\": 0\\.006," LABELS cli)

# The force-smoothness regression gate (lib/gate, tests/gate/baselines.yaml): short replays of
# every committed recording against their baselines; and proof that it can fail (below).
add_test(NAME gate.baselines COMMAND ${EBH_BIN} gate)
set_tests_properties(gate.baselines PROPERTIES PASS_REGULAR_EXPRESSION "gate: passed" LABELS gate TIMEOUT 1200)
# A physical rate of 10 Hz instead of 100 (the physical results reach the tool in coarser jumps)
# moves the force metrics out of their bands (20 Hz did so only without the virtual mesh's
# damping); one physical iteration per step lets the mesh fly apart, which the replay's health
# checks stop: a failed case, and the gate goes on. The recovery is off there: it would redo those
# steps with the direct solve.
add_test(NAME gate.catches_rough_forces
  COMMAND ${EBH_BIN} gate --case gap_insert --set time.physical_hz=10)
set_tests_properties(gate.catches_rough_forces PROPERTIES
  PASS_REGULAR_EXPRESSION "gap_insert +FAIL.*peak_force .N. [0-9.]+ outside the band" LABELS gate TIMEOUT 600)
# --update locks its baselines from reading to writing, says an unwritable folder before any case,
# and keeps its replay outputs in folders of its own under TMPDIR.
find_program(EBH_GATE_BASH bash)
if(EBH_GATE_BASH)
  add_test(NAME gate.update_safety
    COMMAND ${EBH_GATE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/gate/update.sh ${EBH_BIN} ${PROJECT_BINARY_DIR}/cli_gate_update)
  set_tests_properties(gate.update_safety PROPERTIES LABELS gate TIMEOUT 300 PASS_REGULAR_EXPRESSION "gate update: ok")
  # An interrupted replay exits with 128 + signal, not 1 (bad input).
  add_test(NAME cli.safety.interrupt_status
    COMMAND ${EBH_GATE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/interrupt_status.sh ${EBH_BIN} ${PROJECT_BINARY_DIR}/cli_interrupt)
  set_tests_properties(cli.safety.interrupt_status PROPERTIES LABELS cli TIMEOUT 120
    PASS_REGULAR_EXPRESSION "interrupt status: ok")
endif()
# A case with no baseline metric compares nothing: it fails, and a failed gate exits 2 (not 1, bad
# input, nor 0).
file(WRITE ${PROJECT_BINARY_DIR}/gate_no_metrics.yaml
  "cases:\n  - {name: bare, scene: tube, recording: tube_insert, start: 2, duration: 0.1}\n")
if(EBH_GATE_BASH)
  add_test(NAME gate.case_without_baselines_fails
    COMMAND ${EBH_GATE_BASH} -c "\"$0\" gate --baselines \"$1\"; echo \"exit status $?\"" ${EBH_BIN}
      ${PROJECT_BINARY_DIR}/gate_no_metrics.yaml)
  set_tests_properties(gate.case_without_baselines_fails PROPERTIES LABELS gate PASS_REGULAR_EXPRESSION
    "bare +FAIL.*bare: no baseline metric to compare against.*gate: FAILED\nexit status 2")
endif()
# A gate run over a baselines file of one case, written here (BUILD/gate_FILE.yaml): test
# gate.NAME passes when its output matches REGEX.
function(ebh_gate_output name file case regex)
  file(WRITE ${PROJECT_BINARY_DIR}/gate_${file}.yaml "cases:\n  - {${case}}\n")
  add_test(NAME gate.${name} COMMAND ${EBH_BIN} gate --baselines ${PROJECT_BINARY_DIR}/gate_${file}.yaml)
  set_tests_properties(gate.${name} PROPERTIES LABELS gate PASS_REGULAR_EXPRESSION "${regex}")
endfunction()
# A case whose baselines lack some metrics (an older or hand-edited file) passes on the rest and
# names those it did not compare, with their unit as the failures name them.
ebh_gate_output(case_with_some_baselines_names_the_rest some_metrics
  "name: some, scene: tube, recording: tube_insert, start: 2, duration: 0.1, rms_force_step: 1, max_force_rate: 1e6, peak_force: 0.5"
  "some: not compared, no baseline: penetration_max \\[m\\], power_above_30hz, boundary_step_ratio, force_collapse \\(`ebh gate --update` writes them\\)")
# The JSON report gives each metric measured and its baseline under keys with their unit (as
# metrics --json), null where the baselines have none, and lists the unchecked ones under the same
# keys.
add_test(NAME gate.json_measured_and_baseline COMMAND ${EBH_BIN} gate --json
  --baselines ${PROJECT_BINARY_DIR}/gate_some_metrics.yaml)
set_tests_properties(gate.json_measured_and_baseline PROPERTIES LABELS gate PASS_REGULAR_EXPRESSION
  "\"measured\": {\n +\"rms_force_step_N\": [0-9.e-]+,\n +\"max_force_rate_N_per_s\": [0-9.e+-]+,\n +\"peak_force_N\": 0\\.[0-9]+,.*\"penetration_max_m\": [0-9.e-]+,.*\"baseline\": {\n +\"rms_force_step_N\": 1,\n +\"max_force_rate_N_per_s\": 1000000,\n +\"peak_force_N\": 0\\.5,\n +\"power_above_30hz\": null,\n +\"penetration_max_m\": null.*\"unchecked\": \\[\n +\"penetration_max_m\",\n +\"power_above_30hz\",\n +\"boundary_step_ratio\",\n +\"force_collapse\"\n +\\]")
# A window too short for a spectrum (3 ticks) has no power above 30 Hz and, with a still force, no
# frame ratio: the table prints them as ebh metrics does, "-", not "nan".
ebh_gate_output(a_missing_measure_is_a_dash too_short
  "name: brief, scene: tube, recording: tube_insert, start: 2, duration: 0.003, rms_force_step: 1, max_force_rate: 1e6, peak_force: 0"
  "brief +ok    rms dF [0-9.e+-]+ N  max dF/dt +[0-9.]+ N/s  peak [0-9.]+ N  >30 Hz -  pen [0-9.]+ mm  frame ratio -\n")
set_tests_properties(gate.a_missing_measure_is_a_dash PROPERTIES FAIL_REGULAR_EXPRESSION "[^a-z]nan[^a-z]")
# The peak force's band is a factor either way: a baseline of twice the force fails as half of it
# does (a band of +-50% let it pass).
ebh_gate_output(half_the_baselines_force_fails twice_the_force
  "name: twice, scene: tube, recording: tube_insert, start: 1.8, duration: 2, peak_force: 1.1450714"
  "twice: peak_force \\[N\\] 0\\.57[0-9]* outside the band around 1\\.145[0-9]* \\(0\\.663[0-9]* \\.\\. 1\\.8[0-9]*\\)")
# What a replay of a case says is said by the gate too, under the case's name: a recording of
# another scene, a window past the recording's end.
ebh_gate_output(says_the_replays_warnings other_scene
  "name: other, scene: tube_forceps, recording: tube_insert, start: 9.9, duration: 5, peak_force: 0.5"
  "warning: other: .*tube_insert.h5: recorded for the scene 'tube' .*warning: other: .*the recording ends 0.1 s after the start; measuring those, not the duration's 5 s")
# A TMPDIR that is no folder: one line naming it, exit status 1, before any case (an internal error
# from the file-system library before); bench sizes likewise before its table.
add_test(NAME gate.tmpdir_missing
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};gate;--case;tube_insert"
    "-DEXPECT=^ebh: error: TMPDIR '/nonexistent/ebh_tmp': no such folder \\(the folder for temporary files" -DSTATUS=1
    -DNO_STDOUT=1 -P ${EBH_EXPECT_ERROR})
add_test(NAME cli.bench.sizes_tmpdir_missing
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};bench;sizes;--scene;tube;--levels;0-1;--seconds;0.05"
    "-DEXPECT=^ebh: error: TMPDIR '/nonexistent/ebh_tmp': no such folder" -DSTATUS=1 -DNO_STDOUT=1 -P ${EBH_EXPECT_ERROR})
set_tests_properties(gate.tmpdir_missing cli.bench.sizes_tmpdir_missing PROPERTIES
  ENVIRONMENT "TMPDIR=/nonexistent/ebh_tmp" LABELS gate)
# A later case's scene that does not load fails the gate before the first case runs (nothing on
# standard output), naming the case.
file(WRITE ${PROJECT_BINARY_DIR}/gate_missing_scene.yaml "cases:\n"
  "  - {name: good, scene: tube, recording: tube_insert, start: 4, duration: 0.3, peak_force: 0.5}\n"
  "  - {name: gone, scene: no_such_scene, recording: gap_insert, start: 2, duration: 0.3, peak_force: 0.5}\n")
add_test(NAME gate.missing_scene_before_any_case
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};gate;--baselines;${PROJECT_BINARY_DIR}/gate_missing_scene.yaml"
    "-DEXPECT=^ebh: error: [^\n]*gate_missing_scene.yaml:3: cases\\[1\\] \\(gone\\): no_such_scene: no such scene"
    -DSTATUS=1 -DNO_STDOUT=1 -P ${EBH_EXPECT_ERROR})
set_tests_properties(gate.missing_scene_before_any_case PROPERTIES LABELS gate)
# Baselines measured under an override would be every later plain run's reference: refused.
add_test(NAME gate.update_with_set_is_refused
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};gate;--baselines;${PROJECT_BINARY_DIR}/gate_twice_the_force.yaml;--update;--set;stiffness.k_con=800"
    "-DEXPECT=^ebh: error: --update with --set stiffness.k_con=800: baselines measured under an override" -P ${EBH_EXPECT_ERROR})
set_tests_properties(gate.update_with_set_is_refused PROPERTIES LABELS gate)
add_test(NAME gate.reports_a_stopped_replay
  COMMAND ${EBH_BIN} gate --case gap_insert --set solver.physical_iterations=1 --set solver.physical_tolerance=0
    --set solver.recovery=none)
set_tests_properties(gate.reports_a_stopped_replay PROPERTIES
  PASS_REGULAR_EXPRESSION "gap_insert +FAIL  stopped by the health checks.*the replay stopped: .*physical step [0-9]+: the physical mesh diverged.*gate: FAILED"
  LABELS gate TIMEOUT 600)

# Numerical robustness (lib/solver, lib/schedule health checks): the stability matrix's short form,
# absurd physical values, pinning everything or nothing, the solver's convergence in scene info.
set(EBH_NUM_OUT ${PROJECT_BINARY_DIR}/cli_numerics)
file(MAKE_DIRECTORY ${EBH_NUM_OUT})
add_test(NAME cli.validate.stability COMMAND ${EBH_BIN} validate stability)
set_tests_properties(cli.validate.stability PROPERTIES PASS_REGULAR_EXPRESSION "stability +0 of 18 cases non-finite or blown up \\([0-9]+ recovered by the health checks\\)  passed"
  LABELS "cli;validate")
# A user's --set reaches every scene the matrix replays: the solver starved (1 iteration, no
# stopping rule, no recovery) blows up every case of gap_insert's, and the verdict says so.
add_test(NAME cli.validate.stability_under_an_override
  COMMAND ${EBH_BIN} validate stability --recording gap_insert --set solver.physical_iterations=1
    --set solver.physical_tolerance=0 --set solver.recovery=none)
set_tests_properties(cli.validate.stability_under_an_override PROPERTIES
  PASS_REGULAR_EXPRESSION "stability +9 of 9 cases non-finite or blown up .*  FAILED" LABELS "cli;validate")
# A recording given whose tool touches nothing where the matrix replays it, or too short for its
# window, checks nothing: refused, not passed (the hook 60-80 mm off the tube; 10 ms long).
file(WRITE ${EBH_NUM_OUT}/free.yaml "scene: tube\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [-80, 0, 0], rotvec_deg: [0, 90, 0]}\n  - {t: 2, position_mm: [-60, 0, 0]}\n")
file(WRITE ${EBH_NUM_OUT}/brief.yaml "scene: tube\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [-80, 0, 0], rotvec_deg: [0, 90, 0]}\n  - {t: 0.01, position_mm: [-79, 0, 0]}\n")
foreach(plan free brief)
  add_test(NAME cli.validate.stability_recording_${plan}_made
    COMMAND ${EBH_BIN} synth ${EBH_NUM_OUT}/${plan}.yaml -o ${EBH_NUM_OUT}/${plan}.h5)
  set_tests_properties(cli.validate.stability_recording_${plan}_made PROPERTIES FIXTURES_SETUP stability_${plan} LABELS cli)
endforeach()
add_test(NAME cli.validate.stability_of_a_free_tool
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};validate;stability;--recording;${EBH_NUM_OUT}/free.h5"
    "-DEXPECT=^ebh: error: --recording .*free.h5: .*free.h5: the tool touches no tissue where the matrix replays 0.3 s from 40% of each recording \\(t = 0.8 .. 1.1 s\\), so its cases check nothing of contact"
    -P ${EBH_EXPECT_ERROR})
add_test(NAME cli.validate.stability_of_a_brief_recording
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};validate;stability;--recording;${EBH_NUM_OUT}/brief.h5"
    "-DEXPECT=^ebh: error: --recording .*brief.h5: .*brief.h5 is 0.01 s long, and the matrix replays 0.3 s"
    -P ${EBH_EXPECT_ERROR})
set_tests_properties(cli.validate.stability_of_a_free_tool PROPERTIES FIXTURES_REQUIRED stability_free LABELS "cli;validate")
set_tests_properties(cli.validate.stability_of_a_brief_recording PROPERTIES FIXTURES_REQUIRED stability_brief LABELS "cli;validate")
add_test(NAME cli.validate.set_for_an_analytic_case
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};validate;hertz;--set;stiffness.k_vol=10"
    "-DEXPECT=^ebh: error: --set stiffness.k_vol=10: the hertz validation builds its own scenes \\(--set is for coupling and stability\\)"
    -P ${EBH_EXPECT_ERROR})
set_tests_properties(cli.validate.set_for_an_analytic_case PROPERTIES LABELS cli)
# The two-rate loop's short matrix: gap_insert's first 3 s at 1 and 4 virtual iterations, k_s at
# the scene's and at k_svc (the undamped loop's divergence: tests/schedule/test_virtual_damping.cpp).
add_test(NAME cli.validate.coupling COMMAND ${EBH_BIN} validate coupling --json)
set_tests_properties(cli.validate.coupling PROPERTIES
  PASS_REGULAR_EXPRESSION "\"passed\": true,.*\"judged\": 3,.*\"failed\": 0," LABELS "cli;validate")
# At 10 kHz the virtual mesh keeps 0.976 of its velocity a tick (0.8 at 1 kHz) and, in async mode,
# tube_insert diverges from 2 s at 2.6 s: the stop names the per-tick damping and what to raise
# (from 2 s, before the hook's tip reaches into the tube's wall: no warning of a window that starts
# in the tissue comes before the one-line error).
add_test(NAME cli.replay.diverged_at_a_high_haptic_rate
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_NUM_OUT}/high_rate.h5;--start;2;--duration;1;--set;time.haptic_hz=10000;--set;time.physical_hz=1000;-q"
    "-DEXPECT=^ebh: error: .*tube.yaml: tick [0-9]+, physical step [0-9]+: the physical mesh diverged .*; at 10000 Hz the virtual mesh keeps 0.97561 of its velocity a tick \\(0.8 at the scenes' 1 kHz\\), .*raise solver.virtual_damping to about 2500 / s or replay --mode lockstep"
    -DOUTPUT=${EBH_NUM_OUT}/high_rate.h5 -DSTATUS=4 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.replay.diverged_at_a_high_haptic_rate PROPERTIES LABELS cli TIMEOUT 300)
add_test(NAME cli.replay.absurd_gravity
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_NUM_OUT}/g.h5;--duration;0.1;--set;gravity=[0,0,-1e30]"
    "-DEXPECT=^ebh: error: --set 'gravity=\\[0,0,-1e30\\]': key 'gravity': \\|g\\| = 1e\\+30 m/s\\^2 is beyond 100 g" -DOUTPUT=${EBH_NUM_OUT}/g.h5
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.absurd_stiffness
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_NUM_OUT}/k.h5;--duration;0.1;--set;stiffness.k_vol=1e200"
    "-DEXPECT=^ebh: error: .*key 'stiffness.k_vol': 1e\\+200 is beyond 1e12" -DOUTPUT=${EBH_NUM_OUT}/k.h5
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.nothing_pinned_under_gravity
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_NUM_OUT}/p.h5;--duration;0.1;--set;pinned=[];--set;gravity=[0,0,-9.81]"
    "-DEXPECT=^ebh: error: .*tube.yaml: nothing is pinned, so under gravity the physical mesh has no static equilibrium"
    -DOUTPUT=${EBH_NUM_OUT}/p.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# The gap's two blocks with only the right one's bottom pinned: the left block floats free.
add_test(NAME cli.replay.free_part_under_gravity
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;gap;gap_insert;-o;${EBH_NUM_OUT}/fp.h5;--duration;0.1;--set;pinned=[{box: {min: [0,-30,-31], max: [31,30,-29]}}]"
    "-DEXPECT=^ebh: error: .*gap.yaml: 1 part\\(s\\) of the physical mesh touch no pinned vertex \\(the first holds vertex 0 \\(node id [0-9]+\\) and 1928 vertices\\), so under gravity"
    -DOUTPUT=${EBH_NUM_OUT}/fp.h5 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.free_part_warns
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_NUM_OUT}/fpw.h5 --duration 0.02 --set stages.settle=false
    --set "pinned=[{box: {min: [0,-30,-31], max: [31,30,-29]}}]")
set_tests_properties(cli.replay.free_part_warns PROPERTIES PASS_REGULAR_EXPRESSION
  "gap.yaml: pinned: 1 part\\(s\\) of the physical mesh \\(1928 of its 3850 vertices; the first holds vertex 0 \\(node id [0-9]+\\) and 1928 vertices\\) touch no pinned vertex: they float free")
# More haptic threads than the OpenMP threads leave beside the physical step: said, with the number
# run; more OpenMP threads than the machine runs at once: said (they take turns).
add_test(NAME cli.replay.haptic_threads_clamped
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_NUM_OUT}/threads.h5 --duration 0.01 --haptic-threads 4096 -q)
set_tests_properties(cli.replay.haptic_threads_clamped PROPERTIES LABELS cli ENVIRONMENT OMP_NUM_THREADS=2
  PASS_REGULAR_EXPRESSION "warning: --haptic-threads 4096: of the 2 OpenMP threads .* the haptic side runs 1;")
# The direct method stops after its iterations: steps it leaves far from balance (a stiffness far
# above the others) are said, as the iterative methods' capped and stalled steps are.
add_test(NAME cli.replay.direct_steps_short_of_balance
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_NUM_OUT}/direct_short.h5 --start 3 --duration 0.1
    --set stiffness.k_det=1e6 --set solver.method=direct -q)
set_tests_properties(cli.replay.direct_steps_short_of_balance PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "direct_short.h5: 11 of 11 physical steps left up to [0-9.]+ mesh weights unbalanced after their 8 local-global iterations \\(solver.method: direct stops after solver.physical_iterations\\)")
add_test(NAME cli.replay.direct_steps_balanced_quiet
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_NUM_OUT}/direct_balanced.h5 --start 3 --duration 0.1
    --set solver.method=direct -q)
set_tests_properties(cli.replay.direct_steps_balanced_quiet PROPERTIES LABELS cli FAIL_REGULAR_EXPRESSION "unbalanced")
# A physical mesh placed 1e9 m from the origin (1e10 times its size) replays on the CPU, its steps
# stalling on double's round-off of its positions: the warning names that first, with the
# translation that brings the mesh back, before the mesh and the stiffnesses.
add_test(NAME cli.replay.far_mesh_stalls_on_round_off
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_NUM_OUT}/far.h5 --duration 0.3 --allow-outside
    --set "mesh.transform.translate=[1e12, 0, 0]" -q)
set_tests_properties(cli.replay.far_mesh_stalls_on_round_off PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "far.h5: [0-9]+ of 31 physical steps stopped when their iterations stalled, .*/physical/residual\\): the physical mesh's centre lies 1e\\+09 m from the world's origin, 9.6e\\+09 times its size, where double's round-off of its positions \\(1.1e-07 m\\) can leave what they stall at: move the mesh near the origin \\(mesh.transform.translate: \\[0, 0, 0\\], in mm\\) and the recording's poses by as much; else the iteration makes no headway on this mesh")
# So does a fixed iteration count of an iterative method (solver.physical_tolerance 0, the
# paper's fixed K): on tube_grasp 8 Chebyshev iterations let the residual grow from step to step
# (0.9 mesh weights in this window, steps recovered later), judged against the default tolerance;
# 32 leave less than five times it here.
add_test(NAME cli.replay.fixed_iterations_short_of_balance
  COMMAND ${EBH_BIN} replay tube_forceps tube_grasp -o ${EBH_NUM_OUT}/fixed_short.h5 --start 0.8 --duration 0.4
    --set solver.physical_tolerance=0 --set solver.physical_iterations=8 -q)
set_tests_properties(cli.replay.fixed_iterations_short_of_balance PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "fixed_short.h5: [0-9]+ of 41 physical steps left up to [0-9.]+ mesh weights unbalanced after their 8 iterations \\(solver.physical_tolerance 0: a fixed count, no stopping rule\\), more than 5 times the default solver.physical_tolerance, 0.002;.*or let the stopping rule run the steps that need more \\(solver.physical_tolerance: 0.002\\)")
add_test(NAME cli.replay.fixed_iterations_balanced_quiet
  COMMAND ${EBH_BIN} replay tube_forceps tube_grasp -o ${EBH_NUM_OUT}/fixed_balanced.h5 --start 0.8 --duration 0.4
    --set solver.physical_tolerance=0 --set solver.physical_iterations=32 -q)
set_tests_properties(cli.replay.fixed_iterations_balanced_quiet PROPERTIES LABELS cli FAIL_REGULAR_EXPRESSION "unbalanced")
# In lockstep the ticks and the step take turns with all the threads: the option does nothing.
add_test(NAME cli.replay.haptic_threads_in_lockstep
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_NUM_OUT}/threads_lockstep.h5 --duration 0.01 --mode lockstep
    --haptic-threads 1 -q)
set_tests_properties(cli.replay.haptic_threads_in_lockstep PROPERTIES LABELS cli ENVIRONMENT OMP_NUM_THREADS=2
  PASS_REGULAR_EXPRESSION "warning: --haptic-threads 1: not used in lockstep, where the ticks and the physical step take turns, each with all 2 OpenMP threads")
add_test(NAME cli.replay.threads_oversubscribed
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_NUM_OUT}/threads_over.h5 --duration 0.01 -q)
set_tests_properties(cli.replay.threads_oversubscribed PROPERTIES LABELS cli ENVIRONMENT OMP_NUM_THREADS=4096
  PASS_REGULAR_EXPRESSION "warning: 4096 OpenMP threads \\(OMP_NUM_THREADS\\) are more than the [0-9]+ cores this process runs on")
# ... counted on the cores the process may run on (taskset), and without the spin-wait's advice
# where OMP_WAIT_POLICY is passive already.
find_program(EBH_TASKSET taskset)
if(EBH_TASKSET)
  add_test(NAME cli.replay.threads_over_the_affinity
    COMMAND ${EBH_TASKSET} -c 0 ${EBH_BIN} replay tube tube_insert -o ${EBH_NUM_OUT}/threads_affinity.h5 --duration 0.01 -q)
  set_tests_properties(cli.replay.threads_over_the_affinity PROPERTIES LABELS cli
    ENVIRONMENT "OMP_NUM_THREADS=2;OMP_WAIT_POLICY=passive"
    PASS_REGULAR_EXPRESSION "warning: 2 OpenMP threads \\(OMP_NUM_THREADS\\) are more than the 1 core this process runs on: they take turns; set OMP_NUM_THREADS to at most 1\n")
endif()
add_test(NAME cli.table1.seconds_too_short
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};table1;--seconds;0.01"
    "-DEXPECT=^ebh: error: --seconds: expected a finite number in \\[0.1, 3600\\] s, got '0.01'"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.table1.seconds_too_short PROPERTIES LABELS cli)
# The table says what it measured: the machine's load, the threads, and each column's press and
# grasp runs.
add_test(NAME cli.table1.says_what_it_measured COMMAND ${EBH_BIN} table1 --scene tube --seconds 0.1 --json)
set_tests_properties(cli.table1.says_what_it_measured PROPERTIES LABELS cli ENVIRONMENT OMP_NUM_THREADS=2
  PASS_REGULAR_EXPRESSION "\"load_average_before\": [0-9][0-9.e+-]*,\n +\"load_average_after\": [0-9][0-9.e+-]*,.*\"threads\": 2,.*\"pressing\": \{\n +\"scene\": \"tube\",\n +\"recording\": \"tube_insert\",\n +\"start_s\": 1.8\n +\},\n +\"grasping\": \{\n +\"scene\": \"tube_forceps\"")
# A forceps recording that closes its jaws, replayed where nothing grasps: said (and not where the
# scene's forceps grasp, nor for a window in which the jaws stay open).
add_test(NAME cli.replay.grasp_lost_to_a_hook
  COMMAND ${EBH_BIN} replay tube tube_grasp -o ${EBH_NUM_OUT}/lost_hook.h5 --start 1.6 --duration 0.2 -q)
set_tests_properties(cli.replay.grasp_lost_to_a_hook PROPERTIES PASS_REGULAR_EXPRESSION
  "tube_grasp.h5: the jaws close to 0 at the recording's t = 1.700 s \\(below the grasp threshold 0.2\\), but the scene's tool is a hook: nothing is grasped")
add_test(NAME cli.replay.grasp_lost_to_the_stages
  COMMAND ${EBH_BIN} replay tube_forceps tube_grasp -o ${EBH_NUM_OUT}/lost_stage.h5 --start 1.6 --duration 0.2 -q
  --set stages.grasp=false)
set_tests_properties(cli.replay.grasp_lost_to_the_stages PROPERTIES PASS_REGULAR_EXPRESSION
  "tube_grasp.h5: the jaws close to 0 .*but stages.grasp is off: nothing is grasped")
add_test(NAME cli.replay.grasp_kept
  COMMAND ${EBH_BIN} replay tube_forceps tube_grasp -o ${EBH_NUM_OUT}/kept.h5 --duration 0.02 -q)
set_tests_properties(cli.replay.grasp_kept PROPERTIES FAIL_REGULAR_EXPRESSION "nothing is grasped")
add_test(NAME cli.replay.grasp_lost_not_in_the_window
  COMMAND ${EBH_BIN} replay tube tube_grasp -o ${EBH_NUM_OUT}/open_window.h5 --duration 0.02 -q)
set_tests_properties(cli.replay.grasp_lost_not_in_the_window PROPERTIES FAIL_REGULAR_EXPRESSION "nothing is grasped")
set_tests_properties(cli.replay.grasp_lost_to_a_hook cli.replay.grasp_lost_to_the_stages cli.replay.grasp_kept
  cli.replay.grasp_lost_not_in_the_window PROPERTIES LABELS cli)
# A step that ends far from balance (above solver.recovery_residual) and is not redone is said, with
# the count, the largest residual and the first time; the same window with the scene's stiffness is not.
add_test(NAME cli.replay.unbalanced_steps
  COMMAND ${EBH_BIN} replay tube_forceps tube_grasp -o ${EBH_NUM_OUT}/unbalanced.h5 --start 1.55 --duration 0.1 -q
    --set solver.recovery=none --set stiffness.k_det=1e7)
set_tests_properties(cli.replay.unbalanced_steps PROPERTIES PASS_REGULAR_EXPRESSION
  "unbalanced.h5: 3 of 11 physical steps ended with more than 100 mesh weights unbalanced \\(solver.recovery_residual; the largest 1[0-9][0-9], the first at t = 0\\.[0-9]+ s, 1\\.[56][0-9]+ s into the recording; /physical/residual\\).*turn solver.recovery back on")
add_test(NAME cli.replay.balanced_steps
  COMMAND ${EBH_BIN} replay tube_forceps tube_grasp -o ${EBH_NUM_OUT}/balanced.h5 --start 1.55 --duration 0.1 -q)
set_tests_properties(cli.replay.balanced_steps PROPERTIES FAIL_REGULAR_EXPRESSION "unbalanced")
set_tests_properties(cli.replay.absurd_gravity cli.replay.absurd_stiffness cli.replay.nothing_pinned_under_gravity
  cli.replay.free_part_under_gravity cli.replay.free_part_warns cli.replay.unbalanced_steps cli.replay.balanced_steps
  PROPERTIES LABELS cli)
foreach(method chebyshev direct)
  add_test(NAME cli.replay.everything_pinned.${method}
    COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_NUM_OUT}/all_${method}.h5 --duration 0.1 --set solver.method=${method}
      --set "pinned=[{box: {min: [-100,-100,-100], max: [100,100,100]}}]")
  set_tests_properties(cli.replay.everything_pinned.${method} PROPERTIES PASS_REGULAR_EXPRESSION "101 ticks, 11 physical steps" LABELS cli)
endforeach()
add_test(NAME cli.scene.info_solver COMMAND ${EBH_BIN} scene info gap)
set_tests_properties(cli.scene.info_solver PROPERTIES
  PASS_REGULAR_EXPRESSION "histogram +\\[0, 0\\.02\\) 0 .*worst tet +[0-9]+: 0\\.40.*physical solver +bounded diagonal, relaxation 0\\.9: lambda_max\\(D\\^-1 A\\) 2\\.04[0-9]* \\(plain diagonal 2\\.04[0-9]*\\).*iterations per tenfold"
  LABELS cli)

# Files and options cannot hurt a user's data (lib/io/atomic.hpp, lib/io/paths.hpp, docs/FORMATS.md):
# an output over an input is refused and the input stays byte-identical; a write that fails (here a
# file-size limit: write() fails with EFBIG, the path a full disk takes) leaves the previous file
# byte-identical and no temporary; absurd sizes and bad option values are one-line errors.
set(EBH_SAFE ${PROJECT_BINARY_DIR}/cli_safety)
file(MAKE_DIRECTORY ${EBH_SAFE})
# Runs a command with its file-size limit at $1 blocks of 512 bytes (SIGXFSZ as a shell leaves
# it: ebh ignores it itself, or it would die by it, its temporary left behind).
file(WRITE ${EBH_SAFE}/limited.sh "ulimit -f \"$1\" || exit 99\nshift\nexec \"$@\"\n")
# A scene whose mesh is a copy (an output over it must be refused, never tried on the source tree).
file(READ ${PROJECT_SOURCE_DIR}/scenarios/tube.yaml ebh_tube_yaml)
string(REGEX REPLACE "physical: *tube.msh" "physical: ${EBH_SAFE}/tube.msh" ebh_tube_yaml "${ebh_tube_yaml}")
file(WRITE ${EBH_SAFE}/scene.yaml.in "${ebh_tube_yaml}")
string(REGEX REPLACE "time: *{[^}]*}" "time: {haptic_hz: 1e300, physical_hz: 1e300}" ebh_fast_yaml "${ebh_tube_yaml}")
file(WRITE ${EBH_SAFE}/fast_scene.yaml "${ebh_fast_yaml}")
file(WRITE ${EBH_SAFE}/far_plan.yaml
  "scene: tube\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [-80, 0, 0], rotvec_deg: [0, 90, 0]}\n  - {t: 1e12, position_mm: [-80, 0, 0]}\n")
file(WRITE ${EBH_SAFE}/endless.csv "t,x,y,z,qw,qx,qy,qz\n0,-0.08,0,0,0.7071068,0,0.7071068,0\n1e300,-0.08,0,0,0.7071068,0,0.7071068,0\n")
file(WRITE ${EBH_SAFE}/one_sample.csv "t,x,y,z,qw,qx,qy,qz\n0,-0.08,0,0,1,0,0,0\n")
# Gate cases whose window is not one `ebh replay --start --duration` would take.
foreach(window "duration_neg;1;-1" "duration_tiny;4;1e-320" "start_neg;-1;1" "start_past_end;99;1")
  list(GET window 0 wname)
  list(GET window 1 wstart)
  list(GET window 2 wduration)
  file(WRITE ${EBH_SAFE}/gate_${wname}.yaml
    "cases:\n  - {name: w, scene: tube, recording: tube_insert, start: ${wstart}, duration: ${wduration}}\n")
endforeach()
# Gate baselines that would check nothing or pass everything: each refused naming file and key.
set(ebh_gate_case "name: w, scene: tube, recording: tube_insert, start: 4, duration: 0.5")
file(WRITE ${EBH_SAFE}/gate_nan.yaml "cases:\n  - {${ebh_gate_case}, rms_force_step: .nan}\n")
file(WRITE ${EBH_SAFE}/gate_inf.yaml "cases:\n  - {${ebh_gate_case}, peak_force: .inf}\n")
file(WRITE ${EBH_SAFE}/gate_band.yaml "bands: {relative: -1, abs_force_step: 0, abs_force_rate: 0, abs_peak_force: 0, abs_power: 0, abs_penetration: 0}\ncases:\n  - {${ebh_gate_case}}\n")
file(WRITE ${EBH_SAFE}/gate_wide.yaml "bands: {relative: 1e300}\ncases:\n  - {${ebh_gate_case}}\n")
file(WRITE ${EBH_SAFE}/gate_power.yaml "bands: {abs_power: 1}\ncases:\n  - {${ebh_gate_case}}\n")
file(WRITE ${EBH_SAFE}/gate_abs_wide.yaml "bands: {abs_peak_force: 1000}\ncases:\n  - {${ebh_gate_case}}\n")
file(WRITE ${EBH_SAFE}/gate_dup.yaml "cases:\n  - {${ebh_gate_case}, start: 2}\n")
file(WRITE ${EBH_SAFE}/gate_none.yaml "cases: []\n")
file(WRITE ${EBH_SAFE}/gate_extra.yaml "cases:\n  - {${ebh_gate_case}, peak_forse: 1}\n")
file(WRITE ${EBH_SAFE}/gate_twice.yaml "cases:\n  - {${ebh_gate_case}}\n  - {${ebh_gate_case}}\n")
string(REPEAT "[" 100000 ebh_deep_gate)
file(WRITE ${EBH_SAFE}/gate_deep.yaml "cases: ${ebh_deep_gate}\n")
file(WRITE ${EBH_SAFE}/gate_noname.yaml "cases:\n  - {name: '', scene: tube, recording: tube_insert, start: 4, duration: 0.5}\n")
file(WRITE ${EBH_SAFE}/gate_scene.yaml "cases:\n  - {name: w, scene: nope, recording: tube_insert, start: 4, duration: 0.5}\n")
# --update of a window of one tick: no force step to take as a baseline; the file stays as it was.
file(WRITE ${EBH_SAFE}/gate_short.yaml "cases:\n  - {name: w, scene: tube, recording: tube_insert, start: 9.9995, duration: 1}\n")
# --update of a window where the tool never touches (tube_insert's first 0.3 s): a baseline of round-off.
file(WRITE ${EBH_SAFE}/gate_free.yaml "cases:\n  - {name: w, scene: tube, recording: tube_insert, start: 0, duration: 0.3}\n")
# A recording given by a path relative to the baselines file, read from another working folder.
configure_file(${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5 ${EBH_SAFE}/gate_rel/rec.h5 COPYONLY)
file(WRITE ${EBH_SAFE}/gate_rel/sub/own.yaml "cases:\n  - {name: own, scene: tube, recording: ../rec.h5, start: 4, duration: 0.3, peak_force: 0.092}\n")
file(WRITE ${EBH_SAFE}/afile "a file, not a folder\n")
# Inputs named like an unfinished output (not .NAME.: the fixture removes those): a replay output
# (metrics), a scene file, a scene's mesh.
configure_file(${PROJECT_SOURCE_DIR}/tests/data/metrics/press.h5 ${EBH_SAFE}/press.h5.host.1.ebh-partial COPYONLY)
file(WRITE ${EBH_SAFE}/scene.yaml.host.1.ebh-partial "${ebh_tube_yaml}")
string(REGEX REPLACE "physical: *[^\n]*tube.msh" "physical: ${EBH_SAFE}/tube.msh.host.1.ebh-partial" ebh_partial_mesh_yaml "${ebh_tube_yaml}")
file(WRITE ${EBH_SAFE}/partial_mesh.yaml "${ebh_partial_mesh_yaml}")
configure_file(${PROJECT_SOURCE_DIR}/scenarios/tube.msh ${EBH_SAFE}/tube.msh.host.1.ebh-partial COPYONLY)
file(MAKE_DIRECTORY ${EBH_SAFE}/a_folder)
# Fresh copies of the inputs before the tests that must leave them as they were.
add_test(NAME cli.safety.setup COMMAND ${CMAKE_COMMAND}
  -DSAFE=${EBH_SAFE} -DSRC=${PROJECT_SOURCE_DIR} -DEBH=${EBH_BIN} -P ${CMAKE_CURRENT_SOURCE_DIR}/safety_setup.cmake)
set_tests_properties(cli.safety.setup PROPERTIES FIXTURES_SETUP safety LABELS cli)
# ebh_expect_failure(TEST FIXTURE EXPECT [NO_STDOUT] [OUTPUT file] [KEEP files] [PIPES pipes]
#                    [LINKS links] CMD ...): test TEST (label cli, needing FIXTURE) passes when CMD
# exits with status 1 and one stderr line matching EXPECT, nothing on stdout with NO_STDOUT, OUTPUT
# not written, KEEP unchanged, PIPES still named pipes and LINKS still links
# (expect_failure.cmake, expect_failure_keeps_special.cmake).
function(ebh_expect_failure test fixture expect)
  cmake_parse_arguments(ARG "NO_STDOUT" "OUTPUT" "KEEP;PIPES;LINKS;CMD" ${ARGN})
  set(extra)
  if(ARG_NO_STDOUT)
    list(APPEND extra -DNO_STDOUT=1)
  endif()
  if(ARG_OUTPUT)
    list(APPEND extra -DOUTPUT=${ARG_OUTPUT})
  endif()
  add_test(NAME ${test}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${ARG_CMD}" "-DEXPECT=${expect}" "-DKEEP=${ARG_KEEP}" "-DPIPES=${ARG_PIPES}"
      "-DLINKS=${ARG_LINKS}" -DSTATUS=1 ${extra} -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure_keeps_special.cmake)
  set_tests_properties(${test} PROPERTIES FIXTURES_REQUIRED ${fixture} LABELS cli)
endfunction()
function(ebh_safety name expect)
  ebh_expect_failure(cli.safety.${name} safety "${expect}" ${ARGN})
endfunction()
set(S ${EBH_SAFE})
set(REPLACE "the output would replace")
# 1. An output over an input (or a link to it) is refused; the input is untouched.
ebh_safety(replay_over_recording "^ebh: error: .*rec.h5: ${REPLACE} the recording .*rec.h5"
  KEEP ${S}/rec.h5 CMD ${EBH_BIN} replay tube ${S}/rec.h5 -o ${S}/rec.h5 --duration 0.5)
ebh_safety(replay_over_recording_link "^ebh: error: .*link.h5: ${REPLACE} the recording .*rec.h5"
  KEEP ${S}/rec.h5 CMD ${EBH_BIN} replay tube ${S}/rec.h5 -o ${S}/link.h5 --duration 0.5)
ebh_safety(replay_over_scene "^ebh: error: .*scene.yaml: ${REPLACE} the scene file"
  KEEP ${S}/scene.yaml CMD ${EBH_BIN} replay ${S}/scene.yaml tube_insert -o ${S}/scene.yaml)
ebh_safety(replay_over_mesh "^ebh: error: .*tube.msh: ${REPLACE} the scene's physical mesh"
  KEEP ${S}/tube.msh CMD ${EBH_BIN} replay ${S}/scene.yaml tube_insert -o ${S}/tube.msh)
ebh_safety(import_over_log "^ebh: error: .*log.csv: ${REPLACE} the log"
  KEEP ${S}/log.csv CMD ${EBH_BIN} import ${S}/log.csv -o ${S}/log.csv)
ebh_safety(import_over_scene "^ebh: error: .*scene.yaml: ${REPLACE} the scene file"
  KEEP ${S}/scene.yaml CMD ${EBH_BIN} import ${S}/log.csv -o ${S}/scene.yaml --scene ${S}/scene.yaml)
ebh_safety(import_over_mesh "^ebh: error: .*tube.msh: ${REPLACE} the scene's physical mesh"
  KEEP ${S}/tube.msh CMD ${EBH_BIN} import ${S}/log.csv -o ${S}/tube.msh --scene ${S}/scene.yaml)
ebh_safety(synth_over_plan "^ebh: error: .*plan.yaml: ${REPLACE} the plan"
  KEEP ${S}/plan.yaml CMD ${EBH_BIN} synth ${S}/plan.yaml -o ${S}/plan.yaml)
# 2. A write that fails keeps the previous file and says why. 1200 blocks (614 kB) let the
# replay write its rest meshes (522 kB) and fail at the final flush (783 kB); synth fails too.
ebh_safety(replay_write_fails "^ebh: error: .*previous_replay.h5: cannot write the file: File too large"
  KEEP ${S}/previous_replay.h5
  CMD sh ${S}/limited.sh 1200 ${EBH_BIN} replay tube tube_insert -o ${S}/previous_replay.h5 --duration 1 --frames-hz 0 -q)
ebh_safety(synth_write_fails "^ebh: error: .*previous_synth.h5: cannot write the file: File too large"
  KEEP ${S}/previous_synth.h5 CMD sh ${S}/limited.sh 100 ${EBH_BIN} synth ${S}/plan.yaml -o ${S}/previous_synth.h5)
ebh_safety(import_write_fails "^ebh: error: .*previous_import.h5: .*File too large"
  KEEP ${S}/previous_import.h5 CMD sh ${S}/limited.sh 1 ${EBH_BIN} import ${S}/log.csv -o ${S}/previous_import.h5)
# 3. Absurd sizes are refused with the limit before anything is allocated.
ebh_safety(haptic_hz_inf "^ebh: error: --haptic-hz: expected a finite number in \\[10, 100000\\] Hz, got 'inf'"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} replay tube tube_insert -o ${S}/o.h5 --haptic-hz inf)
ebh_safety(haptic_hz_huge "^ebh: error: --haptic-hz: .*got '1e9'"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} replay tube tube_insert -o ${S}/o.h5 --haptic-hz 1e9 --physical-hz 1e7)
ebh_safety(scene_rates_huge "^ebh: error: .*fast_scene.yaml: key 'time.haptic_hz': expected a number in \\[10, 100000\\]"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} replay ${S}/fast_scene.yaml tube_insert -o ${S}/o.h5)
ebh_safety(recording_endless "^ebh: error: .*endless.h5: replaying 1e\\+300 s at 1000 Hz makes .* ticks; the limit is 10000000 ticks"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} replay tube ${S}/endless.h5 -o ${S}/o.h5)
ebh_safety(synth_far_waypoint "^ebh: error: .*far_plan.yaml: the last waypoint at t = 1000000000000 s .* the limit is 10000000 samples"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} synth ${S}/far_plan.yaml -o ${S}/o.h5)
ebh_safety(synth_rate_huge "^ebh: error: --rate: expected a finite number in \\(0, 100000\\] Hz, got '1e9'"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} synth ${S}/plan.yaml -o ${S}/o.h5 --rate 1e9)
# 4. A placement transform whose translation no scene has (here 1e305 m: the tube's unit is mm) is
# refused where it is given, before the poses' coordinates overflow.
ebh_safety(transform_huge "^ebh: error: --transform 1e308,0,0,0,0,0: the translation is 1e\\+305 m long; give one of at most 100 m"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} replay tube tube_insert -o ${S}/o.h5 --transform 1e308,0,0,0,0,0)
ebh_safety(import_transform_huge "^ebh: error: --transform 1e308,0,0,0,0,0: the translation is 1e\\+308 m long"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} import ${S}/log.csv -o ${S}/o.h5 --transform 1e308,0,0,0,0,0)
# 5. A filter that matches nothing is an error listing what exists.
ebh_safety(gate_unknown_case "^ebh: error: --case: no gate case 'nosuchcase' \\(known: tube_insert, "
  CMD ${EBH_BIN} gate --case nosuchcase)
# ... and a gate case's window is checked as replay's --start and --duration are, naming the case.
ebh_safety(gate_duration_neg "^ebh: error: .*gate_duration_neg.yaml:2: key 'cases\\[0\\].duration': expected a finite number of seconds > 0 \\(at least one haptic tick\\), got '-1'"
  CMD ${EBH_BIN} gate --baselines ${S}/gate_duration_neg.yaml)
# A window shorter than one haptic tick replays a single tick, with no force step to measure:
# refused before any case runs, and --update leaves the file as it was.
ebh_safety(gate_duration_tiny "^ebh: error: .*gate_duration_tiny.yaml:2: cases\\[0\\] \\(w\\): duration 1e-320: shorter than one haptic tick \\(0.001 s at 1000 Hz\\).*: expected at least 0.001 s"
  NO_STDOUT KEEP ${S}/gate_duration_tiny.yaml CMD ${EBH_BIN} gate --baselines ${S}/gate_duration_tiny.yaml --update)
ebh_safety(gate_start_neg "^ebh: error: .*gate_start_neg.yaml:2: cases\\[0\\] \\(w\\): start -1: expected a finite number >= 0"
  CMD ${EBH_BIN} gate --baselines ${S}/gate_start_neg.yaml)
ebh_safety(gate_start_past_end "^ebh: error: .*gate_start_past_end.yaml:2: cases\\[0\\] \\(w\\): start 99: the recording .*tube_insert.h5 is 10 s long; start before its end"
  CMD ${EBH_BIN} gate --baselines ${S}/gate_start_past_end.yaml)
foreach(g "nan;cases\\[0\\].rms_force_step': expected a finite number >= 0, got '.nan'"
          "inf;cases\\[0\\].peak_force': expected a finite number >= 0, got '.inf'"
          "band;bands.relative': expected a finite number >= 0, got '-1'"
          "wide;bands.relative': 1e300 lets a metric more than double and pass \\(at most 1"
          "power;bands.abs_power': 1 passes every run"
          "abs_wide;bands.abs_peak_force': 1000 passes every run \\(at most 1 N"
          "dup;cases\\[0\\].start': given twice"
          "none;cases': expected at least one case"
          "extra;cases\\[0\\].peak_forse': unknown key \\(known: name, scene"
          "twice;cases\\[1\\].name': 'w' names two cases"
          "noname;cases\\[0\\].name': expected a name of printable characters, got ''"
          "scene;cases\\[0\\] \\(w\\): nope: no such scene")
  list(GET g 0 gname)
  list(GET g 1 gexpect)
  ebh_safety(gate_${gname} "^ebh: error: .*gate_${gname}.yaml:[0-9]+: (key ')?${gexpect}"
    CMD ${EBH_BIN} gate --baselines ${S}/gate_${gname}.yaml)
endforeach()
ebh_safety(gate_deep "^ebh: error: .*gate_deep.yaml:[0-9]+: nested too deeply \\(over 500 levels of lists and maps"
  CMD ${EBH_BIN} gate --baselines ${S}/gate_deep.yaml)
# (a window the recording's end cuts under one haptic tick: refused before any case runs)
ebh_safety(gate_update_short "^ebh: error: .*gate_short.yaml:2: cases\\[0\\] \\(w\\): start 9.9995: leaves 0.0005 s of the recording .*tube_insert.h5 \\(10 s long\\), less than one haptic tick \\(0.001 s at 1000 Hz\\)"
  KEEP ${S}/gate_short.yaml CMD ${EBH_BIN} gate --baselines ${S}/gate_short.yaml --update)
ebh_safety(gate_update_free "^ebh: error: not updating .*gate_free.yaml: .*cases\\[0\\] \\(w\\): in its window \\(start 0 s, duration 0.3 s\\) the tool never touched the tissue .*: a baseline of a free tool checks nothing"
  KEEP ${S}/gate_free.yaml CMD ${EBH_BIN} gate --baselines ${S}/gate_free.yaml --update)
add_test(NAME cli.gate.path_relative_to_baselines COMMAND ${EBH_BIN} gate --baselines ${S}/gate_rel/sub/own.yaml)
set_tests_properties(cli.gate.path_relative_to_baselines PROPERTIES PASS_REGULAR_EXPRESSION "gate: passed\n"
  FIXTURES_REQUIRED safety LABELS cli)
# A run under --set says so beside its verdict (a --set left in a CI script measures another scene);
# baselines another version measured are said; --update --json leaves stdout to the JSON alone.
add_test(NAME cli.gate.verdict_under_set
  COMMAND ${EBH_BIN} gate --baselines ${S}/gate_rel/sub/own.yaml --set stiffness.k_con=301)
set_tests_properties(cli.gate.verdict_under_set PROPERTIES PASS_REGULAR_EXPRESSION
  "gate: (passed|FAILED) \\(under --set stiffness.k_con=301: not the baselines' scenes\\)\n" FIXTURES_REQUIRED safety LABELS cli)
# A case whose window starts in the middle of a press measures the tissue at rest around the hook:
# said under the case, naming when to start instead.
file(WRITE ${EBH_SAFE}/gate_in_press.yaml
  "cases:\n  - {name: mid_press, scene: cholecystectomy_hook, recording: cholecystectomy_press, start: 1.5, duration: 0.05, peak_force: 0.04}\n")
add_test(NAME cli.gate.window_starts_in_a_press COMMAND ${EBH_BIN} gate --baselines ${S}/gate_in_press.yaml)
set_tests_properties(cli.gate.window_starts_in_a_press PROPERTIES PASS_REGULAR_EXPRESSION
  "warning: mid_press: .*cholecystectomy_press.h5: start 1.5: the replay starts with the tool's tip 1 mm or more inside the tissue .*start at or before 1.16 s into the recording"
  FIXTURES_REQUIRED safety LABELS cli)
file(WRITE ${EBH_SAFE}/gate_rel/sub/old.yaml
  "generated_by: ebh gate --update (ebh 0.0.1)\ncases:\n  - {name: own, scene: tube, recording: ../rec.h5, start: 4, duration: 0.3, peak_force: 0.092}\n")
add_test(NAME cli.gate.baselines_of_another_version COMMAND ${EBH_BIN} gate --baselines ${S}/gate_rel/sub/old.yaml)
set_tests_properties(cli.gate.baselines_of_another_version PROPERTIES PASS_REGULAR_EXPRESSION
  "ebh: warning: .*old.yaml: generated_by 'ebh gate --update \\(ebh 0.0.1\\)', not this ebh [0-9.]+: a change between"
  FIXTURES_REQUIRED safety LABELS cli)
if(EBH_GATE_BASH)
  add_test(NAME cli.gate.update_json_alone
    COMMAND ${EBH_GATE_BASH} -c "cp \"$1/own.yaml\" \"$1/json.yaml\" && out=$(\"$0\" gate --baselines \"$1/json.yaml\" --update --json 2>/dev/null) && [ \"\${out:0:1}\" = '[' ] && [ \"\${out: -1}\" = ']' ] && echo 'JSON alone'"
      ${EBH_BIN} ${S}/gate_rel/sub)
  set_tests_properties(cli.gate.update_json_alone PROPERTIES PASS_REGULAR_EXPRESSION "^JSON alone\n$"
    FIXTURES_REQUIRED safety LABELS cli)
endif()
# 6. Every numeric option is finite and in range.
foreach(bad "start;nan;>= 0" "duration;nan;> 0" "duration;0;> 0" "frames-hz;-5;in \\[0, 100000\\] Hz" "frames-hz;nan;in \\[0")
  list(GET bad 0 opt)
  list(GET bad 1 value)
  list(GET bad 2 range)
  string(REPLACE "-" "_" tname "${opt}_${value}")
  ebh_safety(${tname} "^ebh: error: --${opt}: expected a finite number ${range}.*, got '${value}'"
    OUTPUT ${S}/o.h5 CMD ${EBH_BIN} replay tube tube_insert -o ${S}/o.h5 --${opt} ${value})
endforeach()
ebh_safety(synth_rate_zero "^ebh: error: --rate: expected a finite number in \\(0, 100000\\] Hz, got '0'"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} synth ${S}/plan.yaml -o ${S}/o.h5 --rate 0)
ebh_safety(frames_faster_than_ticks "^ebh: error: --frames-hz 5000: more snapshots than haptic ticks \\(1000 Hz\\)"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} replay tube tube_insert -o ${S}/o.h5 --frames-hz 5000)
# 7. A one-sample recording names the file and what is wrong.
ebh_safety(one_sample "^ebh: error: .*one_sample.csv: the recording has one sample; a recording needs at least two"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} import ${S}/one_sample.csv -o ${S}/o.h5)
# 8. An output in a file that is not a folder: the final name and the OS reason, before any work.
ebh_safety(output_under_a_file "^ebh: error: .*afile/out.h5: cannot create the output: Not a directory"
  CMD ${EBH_BIN} replay tube tube_insert -o ${S}/afile/out.h5)
ebh_safety(import_output_under_a_file "^ebh: error: .*afile/out.h5: cannot create the output: Not a directory"
  CMD ${EBH_BIN} import ${S}/log.csv -o ${S}/afile/out.h5)
# 9. An unfinished output is never an input.
ebh_safety(partial_as_input "^ebh: error: .*ebh-partial: an unfinished output of ebh"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} replay tube ${S}/.unfinished.h5.host.1.ebh-partial -o ${S}/o.h5)
ebh_safety(partial_replay_to_metrics "^ebh: error: .*press.h5.host.1.ebh-partial: an unfinished output of ebh"
  CMD ${EBH_BIN} metrics ${S}/press.h5.host.1.ebh-partial)
ebh_safety(partial_scene "^ebh: error: .*scene.yaml.host.1.ebh-partial: an unfinished output of ebh"
  CMD ${EBH_BIN} scene info ${S}/scene.yaml.host.1.ebh-partial)
ebh_safety(partial_mesh "^ebh: error: .*tube.msh.host.1.ebh-partial: an unfinished output of ebh"
  CMD ${EBH_BIN} scene info ${S}/partial_mesh.yaml)
# 10. import: a folder, a binary file and an unknown scene.
ebh_safety(import_folder "^ebh: error: .*a_folder: is a folder, not a file"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} import ${S}/a_folder -o ${S}/o.h5)
ebh_safety(import_binary "^ebh: error: .*rec.h5:2: byte 0x1a: not a text file"
  OUTPUT ${S}/o.h5 KEEP ${S}/rec.h5 CMD ${EBH_BIN} import ${S}/rec.h5 -o ${S}/o.h5 --format csv)
ebh_safety(import_unknown_scene "^ebh: error: --scene: nosuchscene: no such scene"
  OUTPUT ${S}/o.h5 CMD ${EBH_BIN} import ${S}/log.csv -o ${S}/o.h5 --scene nosuchscene)
# What a command prints is an output too: JSON into a full disk (/dev/full) is an error.
if(EXISTS /dev/full)
  file(WRITE ${EBH_SAFE}/to_full.sh "exec \"$@\" > /dev/full\n")
  ebh_safety(stdout_full "^ebh: error: standard output: No space left on device"
    CMD sh ${S}/to_full.sh ${EBH_BIN} scene info ${CMAKE_CURRENT_SOURCE_DIR}/data/scene/cube.yaml --json)
endif()
add_test(NAME cli.scene.degrade COMMAND ${EBH_BIN} scene degrade tube --quality 0.02 -o ${EBH_NUM_OUT})
set_tests_properties(cli.scene.degrade PROPERTIES FIXTURES_SETUP degraded_tube LABELS cli
  PASS_REGULAR_EXPRESSION "tube_q0.02.yaml: tube with worst mean ratio 0.02 \\(tet [0-9]+; [0-9]+ caps, [0-9]+ slivers, [0-9]+ needles\\)")
add_test(NAME cli.replay.plain_diagonal_diverges_on_slivers
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;${EBH_NUM_OUT}/tube_q0.02.yaml;tube_insert;-o;${EBH_NUM_OUT}/plain.h5;--duration;1;--set;solver.diagonal=plain;--set;solver.recovery=none"
    "-DEXPECT=^ebh: error: .*tube_q0.02.yaml: tick [0-9]+, physical step [0-9]+: the physical mesh (diverged|is not finite) .*its worst tet [0-9]+ has mean ratio .*use bounded"
    -DOUTPUT=${EBH_NUM_OUT}/plain.h5 -DSTATUS=4 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.replay.bounded_diagonal_on_slivers
  COMMAND ${EBH_BIN} replay ${EBH_NUM_OUT}/tube_q0.02.yaml tube_insert -o ${EBH_NUM_OUT}/bounded.h5 --duration 1)
set_tests_properties(cli.replay.bounded_diagonal_on_slivers PROPERTIES PASS_REGULAR_EXPRESSION "1001 ticks, 101 physical steps")
add_test(NAME cli.replay.recovery_redoes_diverging_steps
  COMMAND ${EBH_BIN} replay ${EBH_NUM_OUT}/tube_q0.02.yaml tube_insert -o ${EBH_NUM_OUT}/recovered.h5 --duration 1
    --set solver.diagonal=plain)
set_tests_properties(cli.replay.recovery_redoes_diverging_steps PROPERTIES PASS_REGULAR_EXPRESSION
  "warning: .*recovered.h5: [1-9][0-9]* of 101 physical steps did not converge and were redone with the direct solve \\([^)]*\\); the first factorised the physical mesh's matrix in [0-9.e+-]+ s, counted in its /timing/physical_step_s\n.*1001 ticks, 101 physical steps")
add_test(NAME cli.replay.stopping_rule_says_when_steps_reach_the_cap
  COMMAND ${EBH_BIN} replay ${EBH_NUM_OUT}/tube_q0.02.yaml tube_insert -o ${EBH_NUM_OUT}/capped.h5 --duration 0.1
    --set solver.physical_tolerance=1e-15 --set solver.physical_max_iterations=20)
set_tests_properties(cli.replay.stopping_rule_says_when_steps_reach_the_cap PROPERTIES PASS_REGULAR_EXPRESSION
  "warning: .*capped.h5: [1-9][0-9]* of 11 physical steps ran solver.physical_max_iterations \\(20\\) and still left more than solver.physical_tolerance \\(1e-15 mesh weights\\)")
set_tests_properties(cli.replay.plain_diagonal_diverges_on_slivers cli.replay.bounded_diagonal_on_slivers
  cli.replay.recovery_redoes_diverging_steps cli.replay.stopping_rule_says_when_steps_reach_the_cap
  PROPERTIES FIXTURES_REQUIRED degraded_tube LABELS cli)
# -o OUT.yaml names the scene file (as for `ebh scene refine`): OUT.yaml and OUT.msh, no folder.
add_test(NAME cli.scene.degrade_to_scene_file
  COMMAND ${EBH_BIN} scene degrade tube --quality 0.05 -o ${EBH_NUM_OUT}/named/bad_tube.yaml)
set_tests_properties(cli.scene.degrade_to_scene_file PROPERTIES LABELS cli FIXTURES_SETUP degraded_named
  PASS_REGULAR_EXPRESSION "named/bad_tube.yaml: tube with worst mean ratio 0.05.* mesh .*named/bad_tube.msh")
# A scene file name in upper case (a Windows tool's habit) is a scene file too, not a folder.
add_test(NAME cli.scene.degrade_to_upper_case_scene_file
  COMMAND ${EBH_BIN} scene degrade tube --quality 0.05 -o ${EBH_NUM_OUT}/upper/BAD_TUBE.YAML)
set_tests_properties(cli.scene.degrade_to_upper_case_scene_file PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "upper/BAD_TUBE.YAML: tube with worst mean ratio 0.05.* mesh .*upper/BAD_TUBE.msh")
# The degraded scene names its mesh beside it by its name: the two move together (to a cluster).
if(EBH_GATE_BASH)
  add_test(NAME cli.scene.degraded_scene_moves_with_its_mesh
    COMMAND ${EBH_GATE_BASH} -c "rm -rf \"$1/moved\" && mv \"$1/named\" \"$1/moved\" && \"$0\" scene info \"$1/moved/bad_tube.yaml\""
      ${EBH_BIN} ${EBH_NUM_OUT})
  set_tests_properties(cli.scene.degraded_scene_moves_with_its_mesh PROPERTIES LABELS cli FIXTURES_REQUIRED degraded_named
    PASS_REGULAR_EXPRESSION "tets +8057")
endif()
add_test(NAME cli.scene.degrade_bad_quality
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;degrade;tube;--quality;1.5;-o;${EBH_NUM_OUT}"
    "-DEXPECT=^ebh: error: --quality: expected a mean ratio in \\(0, 1\\)" -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.scene.degrade_bad_quality PROPERTIES LABELS cli)
# A quality the mesh already has wrote the mesh unchanged as 'degraded'; more tets than the mesh
# has room for degraded fewer without a word.
add_test(NAME cli.scene.degrade_nothing_to_do
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;degrade;tube;--quality;0.9;-o;${EBH_NUM_OUT}/nothing"
    "-DEXPECT=^ebh: error: .*tube.yaml: the physical mesh's worst mean ratio is already 0.3779 \\(tet 7949 \\(element id 11264\\)\\), at or below --quality 0.9: nothing to degrade"
    -DOUTPUT=${EBH_NUM_OUT}/nothing/tube_q0.9.yaml -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.scene.degrade_fewer_than_asked
  COMMAND ${EBH_BIN} scene degrade tube --quality 0.05 --tets 100000 -o ${EBH_NUM_OUT}/fewer)
set_tests_properties(cli.scene.degrade_nothing_to_do cli.scene.degrade_fewer_than_asked PROPERTIES LABELS cli)
set_tests_properties(cli.scene.degrade_fewer_than_asked PROPERTIES PASS_REGULAR_EXPRESSION
  "ebh: warning: .*tube.yaml: degraded 109 of the 100000 tets asked for \\(--tets\\)")
# With -o DIR the outputs are named after the scene's `name`: one that is no file name ('../../x'
# wrote above DIR, an absolute name ignored -o, a line break went into the file's name) is refused
# naming the scene file and the key, before any work, and nothing is written.
set(dir ${EBH_NUM_OUT}/degrade_names)
file(MAKE_DIRECTORY ${dir}/a/b)
file(READ ${PROJECT_SOURCE_DIR}/scenarios/tube.yaml ebh_tube_yaml)
string(REPLACE "physical: tube.msh" "physical: ${PROJECT_SOURCE_DIR}/scenarios/tube.msh" ebh_tube_yaml "${ebh_tube_yaml}")
foreach(case up absolute line_break)
  if(case STREQUAL up)
    set(name "../../up")
    set(written ${dir}/a/up_q0.05.yaml)  # out/../../
    set(why "holds a '/' \\(a path, not a file's name\\)")
  elseif(case STREQUAL absolute)
    set(name "${dir}/absolute")
    set(written ${dir}/absolute_q0.05.yaml)
    set(why "holds a '/'")
  else()
    set(name "nl\\nname")
    set(written ${dir}/a/b/out/nothing_here.yaml)  # its output's name would hold the line break
    set(why "holds a control character")
  endif()
  string(REPLACE "\nname: tube\n" "\nname: \"${name}\"\n" scene_yaml "${ebh_tube_yaml}")
  file(WRITE ${dir}/${case}.yaml "${scene_yaml}")
  add_test(NAME cli.scene.degrade_name_${case}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;degrade;${dir}/${case}.yaml;--quality;0.05;-o;${dir}/a/b/out"
      "-DEXPECT=^ebh: error: .*degrade_names/${case}.yaml: key 'name': '.*' ${why}[^:]*: with -o DIR the outputs are named after it \\(DIR/NAME_q0.05.yaml\\); rename the scene, or give -o OUT.yaml"
      "-DOUTPUT=${written}" -DSTATUS=1 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.scene.degrade_name_${case} PROPERTIES LABELS "cli;scene")
endforeach()
# scene info prints the scene's name escaped (an escape sequence in it coloured the terminal).
string(REPLACE "\nname: tube\n" "\nname: \"cu\\ebe\"\n" scene_yaml "${ebh_tube_yaml}")
file(WRITE ${dir}/escaped.yaml "${scene_yaml}")
add_test(NAME cli.scene.info_name_escaped COMMAND ${EBH_BIN} scene info ${dir}/escaped.yaml)
set_tests_properties(cli.scene.info_name_escaped PROPERTIES LABELS "cli;scene" PASS_REGULAR_EXPRESSION
  "scene +cu\\\\x1bbe \\(")
add_test(NAME cli.replay.settling_says_when_it_stops_short
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_NUM_OUT}/sag.h5 --duration 0.05 --set "gravity=[0,0,-30]"
    --set stiffness.k_vol=30)
set_tests_properties(cli.replay.settling_says_when_it_stops_short PROPERTIES LABELS cli
  PASS_REGULAR_EXPRESSION "warning: --set 'gravity=\\[0,0,-30\\]': \\|gravity\\| = 30.* is over 2 g.*warning: .*tube.yaml: settling under gravity stopped at its cap of 25 static steps")

# A mesh that settles far from its drawn shape (the tube at a third of its stiffness sags by a
# quarter of its size) is said with its largest displacement; the gap's settled blocks are not.
add_test(NAME cli.replay.settling_says_how_far_the_mesh_hangs
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_NUM_OUT}/hangs.h5 --duration 0.01 --set "gravity=[0,0,-9.81]"
    --set stiffness.k_vol=1000)
set_tests_properties(cli.replay.settling_says_how_far_the_mesh_hangs PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "warning: .*tube.yaml: under gravity the physical mesh settles 2[0-9.]+ mm from its shape in the mesh file \\(vertex [0-9]+ \\(node id [0-9]+\\); 2[0-9]% of its bounding-box diagonal\\): it hangs from its pins")
add_test(NAME cli.replay.settling_of_the_gap_is_not_a_hang
  COMMAND ${EBH_BIN} replay gap gap_insert -o ${EBH_NUM_OUT}/gap_settled.h5 --duration 0.01)
set_tests_properties(cli.replay.settling_of_the_gap_is_not_a_hang PROPERTIES LABELS cli
  FAIL_REGULAR_EXPRESSION "hangs from its pins")

# Tissue too soft for its own weight: the settling's divergence names that cause, not only a tet.
add_test(NAME cli.replay.settling_names_tissue_too_soft
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_NUM_OUT}/soft.h5;--duration;0.02;--set;gravity=[0,0,-9.81];--set;stiffness.k_vol=1"
    "-DEXPECT=settling under gravity, static step 1: the physical mesh diverged.*; the tissue is too soft to carry its own weight: .* / stiffness.k_vol = 196.2 "
    -DOUTPUT=${EBH_NUM_OUT}/soft.h5 -DSTATUS=4 -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.replay.settling_names_tissue_too_soft PROPERTIES LABELS cli)

# ebh sweep (lib/sweep): resumption and SIGTERM on real replays, a failed run among good ones, the
# report's Pareto front on a hand-made summary, a bad plan, and a job array on a Slurm started on
# localhost (skipped, saying why, where its daemons cannot start).
set(EBH_SWEEP_OUT ${PROJECT_BINARY_DIR}/cli_sweep)
file(MAKE_DIRECTORY ${EBH_SWEEP_OUT})
find_program(EBH_BASH bash)
if(EBH_BASH)
  add_test(NAME cli.sweep.resume COMMAND ${EBH_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/sweep/resume.sh ${EBH_BIN} ${EBH_SWEEP_OUT}/resume)
  set_tests_properties(cli.sweep.resume PROPERTIES LABELS "cli;sweep" TIMEOUT 180 PASS_REGULAR_EXPRESSION "resume: ok")
  add_test(NAME cli.sweep.slurm COMMAND ${EBH_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/sweep/slurm.sh ${EBH_BIN} ${EBH_SWEEP_OUT}/slurm)
  set_tests_properties(cli.sweep.slurm PROPERTIES LABELS "cli;sweep" TIMEOUT 150 SKIP_RETURN_CODE 77
    PASS_REGULAR_EXPRESSION "slurm: job array [0-9]+ ran 3 runs")
  # A submission that fails (no sbatch, or sbatch refusing) leaves the folder as it was.
  add_test(NAME cli.sweep.slurm_fails
    COMMAND ${EBH_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/sweep/slurm_fails.sh ${EBH_BIN} ${EBH_SWEEP_OUT}/slurm_fails)
  set_tests_properties(cli.sweep.slurm_fails PROPERTIES LABELS "cli;sweep" PASS_REGULAR_EXPRESSION "slurm fails: ok")
  # Another plan into a sweep's folder is refused; the same plan, written otherwise, resumes it.
  add_test(NAME cli.sweep.other_plan
    COMMAND ${EBH_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/sweep/other_plan.sh ${EBH_BIN} ${EBH_SWEEP_OUT}/other_plan
      ${PROJECT_SOURCE_DIR}/scenarios/tube.yaml)
  set_tests_properties(cli.sweep.other_plan PROPERTIES LABELS "cli;sweep" PASS_REGULAR_EXPRESSION "other plan: ok")
  # One sweep at a time in a folder (DIR/.lock); the lock dies with its process.
  add_test(NAME cli.sweep.lock COMMAND ${EBH_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/sweep/lock.sh ${EBH_BIN} ${EBH_SWEEP_OUT}/lock)
  set_tests_properties(cli.sweep.lock PROPERTIES LABELS "cli;sweep" TIMEOUT 300 PASS_REGULAR_EXPRESSION "lock: ok")
  # A run's output deleted after the summary was written: the report names the run and why, does
  # not count it as ok, and collects again; a resumed sweep runs exactly that run.
  add_test(NAME cli.sweep.report_outdated
    COMMAND ${EBH_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/sweep/report_outdated.sh ${EBH_BIN} ${EBH_SWEEP_OUT}/report_outdated)
  set_tests_properties(cli.sweep.report_outdated PROPERTIES LABELS "cli;sweep" TIMEOUT 120
    PASS_REGULAR_EXPRESSION "report outdated: ok")
endif()
# The runs' replays print into their logs; the sweep says each kind of warning once, counted.
file(WRITE ${EBH_SWEEP_OUT}/warned_plan.yaml
  "scenes:\n  - {scene: cholecystectomy_hook, recordings: [cholecystectomy_press], reference: {solver.virtual_iterations: 8}}\ngrid:\n  solver.virtual_iterations: [8, 2]\nstart: 1.5\nduration: 0.02\n")
add_test(NAME cli.sweep.warnings_fresh_folder COMMAND ${CMAKE_COMMAND} -E rm -rf ${EBH_SWEEP_OUT}/warned)
set_tests_properties(cli.sweep.warnings_fresh_folder PROPERTIES LABELS "cli;sweep" FIXTURES_SETUP sweep_warned)
add_test(NAME cli.sweep.warnings_of_the_runs
  COMMAND ${EBH_BIN} sweep ${EBH_SWEEP_OUT}/warned_plan.yaml -o ${EBH_SWEEP_OUT}/warned --jobs 2)
set_tests_properties(cli.sweep.warnings_of_the_runs PROPERTIES LABELS "cli;sweep" FIXTURES_REQUIRED sweep_warned
  PASS_REGULAR_EXPRESSION
  "ebh: warning: the runs' replays warned 2 times \\(the first in [^\n]*/warned/runs/[0-9a-f]+\\.log\\): [^\n]*cholecystectomy_press\\.h5: --start 1\\.5: the replay starts with the tool's tip")
add_test(NAME cli.sweep.report
  COMMAND ${EBH_BIN} sweep report ${CMAKE_CURRENT_SOURCE_DIR}/data/sweep/front --plot ${EBH_SWEEP_OUT}/front.png)
set_tests_properties(cli.sweep.report PROPERTIES LABELS "cli;sweep" PASS_REGULAR_EXPRESSION
  "\\| \\* \\| k=1 \\| 1 \\| 1 \\|.*\\|  \\| k=5 \\|.*\\| \\* \\| k=2 \\| 2 \\| 2\\.2 \\|.*\\|  \\| k=3 \\|.*\\| \\* \\| k=4 \\|.*\\| reference \\| solver\\.method=direct \\|.*failed: f k=6: the replay failed, for a reason with a comma.*1 run not run yet")
file(WRITE ${EBH_SWEEP_OUT}/bad_plan.yaml
  "scenes:\n  - {scene: tube, recordings: [tube_insert], reference: {}}\ngrid:\n  solver.no_such: [1, 2]\n")
add_test(NAME cli.sweep.bad_plan
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};sweep;${EBH_SWEEP_OUT}/bad_plan.yaml;-o;${EBH_SWEEP_OUT}/bad"
    "-DEXPECT=^ebh: error: .*bad_plan.yaml:4: key 'grid.solver.no_such': on scene tube: key 'solver.no_such': unknown key"
    -DOUTPUT=${EBH_SWEEP_OUT}/bad/summary.csv -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# A folder copied from another machine: its plan's files are not here and its summary is older
# than the plan (a copy's times): the report is the summary's, with a warning.
file(COPY ${CMAKE_CURRENT_SOURCE_DIR}/data/sweep/front/summary.csv DESTINATION ${EBH_SWEEP_OUT}/moved)
file(WRITE ${EBH_SWEEP_OUT}/moved/plan.yaml
  "scenes:\n  - {scene: /elsewhere/scenarios/tube.yaml, recordings: [/elsewhere/recordings/tube_insert.h5], reference: {}}\n")
add_test(NAME cli.sweep.report_moved_folder COMMAND ${EBH_BIN} sweep report ${EBH_SWEEP_OUT}/moved)
set_tests_properties(cli.sweep.report_moved_folder PROPERTIES LABELS "cli;sweep" PASS_REGULAR_EXPRESSION
  "warning: .*moved: cannot collect the runs again \\(.*elsewhere.*\\); reporting summary.csv as it is.*\\| \\* \\| k=1 \\|")
# --plot replaces none of the sweep's files: its summary (there or not yet), its plan, a run's
# output; nor does it go into runs/, where a run not done yet has no file to compare with.
file(MAKE_DIRECTORY ${EBH_SWEEP_OUT}/moved/runs)
file(WRITE ${EBH_SWEEP_OUT}/moved/runs/0123456789abcdef.h5 "a run's output\n")
foreach(target summary.csv summary.h5 plan.yaml runs/0123456789abcdef.h5 runs/fedcba9876543210.h5)
  string(MAKE_C_IDENTIFIER ${target} tname)
  if(target MATCHES "fedcba")
    set(why "the output would go into the sweep's folder .*moved/runs, which holds its runs' files only")
  else()
    set(why "the output would replace the sweep's [a-z ]+ .*moved/${target}")
  endif()
  add_test(NAME cli.sweep.report_plot_over_${tname}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};sweep;report;${EBH_SWEEP_OUT}/moved;--plot;${EBH_SWEEP_OUT}/moved/${target}"
      "-DEXPECT=^ebh: error: .*moved/${target}: ${why}" -DNO_STDOUT=1
      "-DKEEP=${EBH_SWEEP_OUT}/moved/summary.csv;${EBH_SWEEP_OUT}/moved/plan.yaml;${EBH_SWEEP_OUT}/moved/runs/0123456789abcdef.h5"
      -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.sweep.report_plot_over_${tname} PROPERTIES LABELS "cli;sweep")
endforeach()
# ... nor a file the plan reads when the summary is fresh and nothing is collected (a plan's
# recording became a PNG).
file(MAKE_DIRECTORY ${EBH_SWEEP_OUT}/fresh)
configure_file(${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5 ${EBH_SWEEP_OUT}/fresh_rec.h5 COPYONLY)
file(WRITE ${EBH_SWEEP_OUT}/fresh/plan.yaml
  "scenes:\n  - {scene: tube, recordings: [${EBH_SWEEP_OUT}/fresh_rec.h5], reference: {}}\n")
configure_file(${CMAKE_CURRENT_SOURCE_DIR}/data/sweep/front/summary.csv ${EBH_SWEEP_OUT}/fresh/summary.csv COPYONLY)
add_test(NAME cli.sweep.fresh_summary COMMAND ${CMAKE_COMMAND} -E touch ${EBH_SWEEP_OUT}/fresh/summary.csv)
set_tests_properties(cli.sweep.fresh_summary PROPERTIES FIXTURES_SETUP fresh_sweep LABELS "cli;sweep")
add_test(NAME cli.sweep.report_plot_over_a_plan_input
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};sweep;report;${EBH_SWEEP_OUT}/fresh;--plot;${EBH_SWEEP_OUT}/fresh_rec.h5"
    "-DEXPECT=^ebh: error: .*fresh_rec.h5: .*would replace the recording" -DNO_STDOUT=1
    "-DKEEP=${EBH_SWEEP_OUT}/fresh_rec.h5" -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.sweep.report_plot_over_a_plan_input PROPERTIES FIXTURES_REQUIRED fresh_sweep LABELS "cli;sweep")
add_test(NAME cli.sweep.report_not_a_sweep
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};sweep;report;${CMAKE_CURRENT_SOURCE_DIR}/data/sweep"
    "-DEXPECT=^ebh: error: .*data/sweep: neither summary.csv nor plan.yaml: not a sweep's folder"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# The active region's size per run (summary.csv's active_vertices_mean): a number with the key, empty without.
if(EBH_BASH)
  add_test(NAME cli.sweep.active_vertices
    COMMAND ${EBH_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/sweep/active_column.sh ${EBH_BIN} ${EBH_SWEEP_OUT}/region)
  set_tests_properties(cli.sweep.active_vertices PROPERTIES LABELS "cli;sweep" PASS_REGULAR_EXPRESSION "active column: ok")
endif()
# --gpus: its form is checked before any work (the devices, once the runs are known: test_sweep).
add_test(NAME cli.sweep.bad_gpus
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};sweep;${EBH_SWEEP_OUT}/bad_plan.yaml;-o;${EBH_SWEEP_OUT}/bad_gpus;--gpus;0,x"
    "-DEXPECT=^ebh: error: --gpus '0,x': expected all or device numbers separated by commas"
    -DOUTPUT=${EBH_SWEEP_OUT}/bad_gpus/plan.yaml -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
set_tests_properties(cli.sweep.bad_plan cli.sweep.report_not_a_sweep cli.sweep.bad_gpus PROPERTIES LABELS "cli;sweep")
# A plan that reads a file the sweep writes (its summary, a file in runs/) is refused before any
# work, and the file stays; so is a folder without plan.yaml that holds a user's summary or files
# in runs/ that are no run's: nothing of the plan is written there.
foreach(sname own_summary own_runs)
  file(REMOVE_RECURSE ${EBH_SWEEP_OUT}/${sname})
endforeach()
configure_file(${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5 ${EBH_SWEEP_OUT}/own_summary/summary.h5 COPYONLY)
configure_file(${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5 ${EBH_SWEEP_OUT}/own_runs/runs/rec.h5 COPYONLY)
foreach(sname own_summary/summary.h5 own_runs/runs/rec.h5)
  get_filename_component(sdir ${sname} DIRECTORY)
  string(REGEX REPLACE "/.*" "" sdir ${sdir})
  file(WRITE ${EBH_SWEEP_OUT}/${sdir}.yaml
    "scenes:\n  - {scene: tube, recordings: [${EBH_SWEEP_OUT}/${sname}], reference: {}}\nstart: 4\nduration: 0.05\n")
endforeach()
add_test(NAME cli.sweep.plan_reads_its_summary
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};sweep;${EBH_SWEEP_OUT}/own_summary.yaml;-o;${EBH_SWEEP_OUT}/own_summary"
    "-DEXPECT=^ebh: error: .*own_summary/summary.h5: the output would replace the recording .*own_summary/summary.h5, an input of this command; give the sweep another folder"
    -DKEEP=${EBH_SWEEP_OUT}/own_summary/summary.h5 -DOUTPUT=${EBH_SWEEP_OUT}/own_summary/plan.yaml
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
add_test(NAME cli.sweep.plan_reads_its_runs
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};sweep;${EBH_SWEEP_OUT}/own_runs.yaml;-o;${EBH_SWEEP_OUT}/own_runs"
    "-DEXPECT=^ebh: error: .*own_runs/runs/rec.h5: the recording is in the sweep's folder .*own_runs/runs, where it writes its runs' files"
    -DKEEP=${EBH_SWEEP_OUT}/own_runs/runs/rec.h5 -DOUTPUT=${EBH_SWEEP_OUT}/own_runs/plan.yaml
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
# (0123456789abcdef.h5: a run's output, as in another sweep's runs/ given as the folder)
foreach(uname summary.csv runs/notes.txt 0123456789abcdef.h5)
  string(MAKE_C_IDENTIFIER ${uname} uid)
  file(REMOVE_RECURSE ${EBH_SWEEP_OUT}/user_${uid})
  file(WRITE ${EBH_SWEEP_OUT}/user_${uid}/${uname} "a user's file\n")
  if(uname MATCHES "runs/")
    set(uwhat "runs/notes.txt, not a run's file")
  elseif(uname MATCHES "^0123")
    set(uwhat "0123456789abcdef.h5, a sweep run's file \\(is it another sweep's runs folder\\?\\)")
  else()
    set(uwhat "summary.csv")
  endif()
  add_test(NAME cli.sweep.not_a_sweep_folder_${uid}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};sweep;${CMAKE_CURRENT_SOURCE_DIR}/data/sweep/tube_one_run.yaml;-o;${EBH_SWEEP_OUT}/user_${uid}"
      "-DEXPECT=^ebh: error: .*user_${uid}: not an ebh sweep folder \\(no plan.yaml\\) but holds ${uwhat}: name a new or empty folder"
      -DKEEP=${EBH_SWEEP_OUT}/user_${uid}/${uname} -DOUTPUT=${EBH_SWEEP_OUT}/user_${uid}/plan.yaml
      -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_failure.cmake)
  set_tests_properties(cli.sweep.not_a_sweep_folder_${uid} PROPERTIES LABELS "cli;sweep")
endforeach()
set_tests_properties(cli.sweep.plan_reads_its_summary cli.sweep.plan_reads_its_runs PROPERTIES LABELS "cli;sweep")
