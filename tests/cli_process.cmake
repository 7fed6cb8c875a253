# A hostile process environment (included after cli.cmake, whose EBH_BIN, EBH_GATE_BASH,
# EBH_EXPECT_ERROR and EBH_HAVE_OSMESA it uses): one line and a non-zero exit, never a crash or a
# hang, and no output left behind.
set(EBH_PROCESS_OUT ${PROJECT_BINARY_DIR}/cli_process)
file(MAKE_DIRECTORY ${EBH_PROCESS_OUT})

# OMP_NUM_THREADS far beyond the machine: libgomp crashed starting 100000 threads (and ran on for
# hours with 30000). Refused before any parallel region, whatever the command.
add_test(NAME cli.process.omp_threads_too_many_scene
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};scene;info;tube"
    "-DEXPECT=^ebh: error: OMP_NUM_THREADS '100000': far more threads than this machine runs at once .*: at most [0-9]+ are accepted"
    -DSTATUS=1 -P ${EBH_EXPECT_ERROR})
add_test(NAME cli.process.omp_threads_too_many_replay
  COMMAND ${CMAKE_COMMAND}
    "-DCMD=${EBH_BIN};replay;tube;tube_insert;-o;${EBH_PROCESS_OUT}/many_threads.h5;--duration;0.1"
    "-DEXPECT=^ebh: error: OMP_NUM_THREADS '100000': far more threads" -DOUTPUT=${EBH_PROCESS_OUT}/many_threads.h5
    -DSTATUS=1 -P ${EBH_EXPECT_ERROR})
set_tests_properties(cli.process.omp_threads_too_many_scene cli.process.omp_threads_too_many_replay PROPERTIES
  LABELS cli ENVIRONMENT OMP_NUM_THREADS=100000 TIMEOUT 60)
# A value OpenMP's syntax allows runs: one count per nesting level.
add_test(NAME cli.process.omp_threads_per_level COMMAND ${EBH_BIN} scene info tube)
set_tests_properties(cli.process.omp_threads_per_level PROPERTIES LABELS cli ENVIRONMENT "OMP_NUM_THREADS=2,1")
# A value that is no thread count: libgomp warns at load time (which ebh cannot stop) and ignores
# it; ebh then refuses it with its own line rather than run on with threads the user did not ask
# for. The test drops libgomp's lines and checks ebh's line and exit status.
if(EBH_GATE_BASH)
  # name=value pairs; '' (set, empty) is the last.
  foreach(pair IN ITEMS zero=0 negative=-1 word=abc exponent=1e3 empty_level=4, empty=)
    string(REGEX REPLACE "=.*" "" name "${pair}")
    string(REGEX REPLACE "^[^=]*=" "" value "${pair}")
    add_test(NAME cli.process.omp_threads_invalid_${name}
      COMMAND ${EBH_GATE_BASH} -c
        "err=$(OMP_NUM_THREADS='${value}' \"$0\" scene info tube 2>&1 >/dev/null); rc=$?; printf '%s\\n' \"$err\" | grep -v '^libgomp: \\|^$'; echo \"exit status $rc\""
        ${EBH_BIN})
    set_tests_properties(cli.process.omp_threads_invalid_${name} PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
      "^ebh: error: OMP_NUM_THREADS '${value}': not a number of threads \\([^\n]*\\)\nexit status 1\n$")
  endforeach()
endif()

# An interrupt while ffmpeg assembles `render --video`'s video stops ffmpeg too: it was left
# running (its parent gone) after the interrupt's grace, writing on into the video's temporary,
# and a signal to the process group (`timeout`) was said as ffmpeg failing.
if(EBH_HAVE_OSMESA AND EBH_GATE_BASH)
  add_test(NAME cli.process.video_interrupt
    COMMAND ${EBH_GATE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/video_interrupt.sh ${EBH_BIN} ${EBH_RENDER_OUT}/tube.h5
      ${EBH_PROCESS_OUT}/video_interrupt)
  set_tests_properties(cli.process.video_interrupt PROPERTIES FIXTURES_REQUIRED render_tube LABELS "cli;render"
    TIMEOUT 180 PASS_REGULAR_EXPRESSION "video interrupt: ok")
endif()

# A scene or recording that is a symbolic link to itself: the OS's reason, not "file not found".
file(CREATE_LINK loop.yaml ${EBH_PROCESS_OUT}/loop.yaml SYMBOLIC)
file(CREATE_LINK loop.h5 ${EBH_PROCESS_OUT}/loop.h5 SYMBOLIC)
# `ebh replay SCENE RECORDING` refused (status 1, one line matching EXPECT, no output written).
function(ebh_process_replay_failure name scene recording expect)
  add_test(NAME cli.process.${name}
    COMMAND ${CMAKE_COMMAND}
      "-DCMD=${EBH_BIN};replay;${scene};${recording};-o;${EBH_PROCESS_OUT}/${name}.h5;--duration;0.1"
      "-DEXPECT=${expect}" -DOUTPUT=${EBH_PROCESS_OUT}/${name}.h5 -DSTATUS=1 -P ${EBH_EXPECT_ERROR})
  set_tests_properties(cli.process.${name} PROPERTIES LABELS cli)
endfunction()
ebh_process_replay_failure(scene_link_loop ${EBH_PROCESS_OUT}/loop.yaml tube_insert
  "^ebh: error: [^\n]*/loop.yaml: cannot be opened: Too many levels of symbolic links\n$")
ebh_process_replay_failure(recording_link_loop tube ${EBH_PROCESS_OUT}/loop.h5
  "^ebh: error: [^\n]*/loop.h5: cannot be opened: Too many levels of symbolic links\n$")
# The same found by a bare name in EBH_DATA_DIR (said "no such scene"), and a link to nothing.
file(MAKE_DIRECTORY ${EBH_PROCESS_OUT}/data/scenarios ${EBH_PROCESS_OUT}/data/recordings)
file(CREATE_LINK loopy.yaml ${EBH_PROCESS_OUT}/data/scenarios/loopy.yaml SYMBOLIC)
file(CREATE_LINK moved_away.h5 ${EBH_PROCESS_OUT}/data/recordings/dangling.h5 SYMBOLIC)
ebh_process_replay_failure(scene_name_link_loop loopy tube_insert
  "^ebh: error: [^\n]*/data/scenarios/loopy.yaml: cannot be opened: Too many levels of symbolic links\n$")
ebh_process_replay_failure(recording_name_dangling_link tube dangling
  "^ebh: error: [^\n]*/data/recordings/dangling.h5: is a link to moved_away.h5, which does not exist\n$")
set_tests_properties(cli.process.scene_name_link_loop cli.process.recording_name_dangling_link PROPERTIES
  ENVIRONMENT EBH_DATA_DIR=${EBH_PROCESS_OUT}/data)

# Signals whose default action would end a run without a word and leave its temporary (SIGUSR1,
# SIGUSR2, SIGALRM, SIGXCPU, SIGVTALRM, SIGPROF) stop it as SIGTERM does; one ignored at the start
# stays ignored.
if(EBH_GATE_BASH)
  add_test(NAME cli.process.stop_signals
    COMMAND ${EBH_GATE_BASH} ${CMAKE_CURRENT_SOURCE_DIR}/stop_signals.sh ${EBH_BIN} ${EBH_PROCESS_OUT}/stop_signals)
  set_tests_properties(cli.process.stop_signals PROPERTIES LABELS cli TIMEOUT 60 PASS_REGULAR_EXPRESSION
    "stop signals: ok")
endif()

# Started with its standard streams closed (`>&-`), ebh runs with them on /dev/null: a file it
# opens does not take their numbers, so nothing printed lands in an output, and the summary
# printed to a closed stdout is no error. The output is a whole HDF5 file (its signature).
if(EBH_GATE_BASH)
  add_test(NAME cli.process.closed_standard_streams
    COMMAND ${EBH_GATE_BASH} -c
      "\"$0\" replay tube tube_insert -o \"$1\" --duration 0.1 <&- >&- 2>&-; echo \"exit status $?\"; head -c 4 \"$1\" | tail -c 3; echo; ! grep -aq 'physical steps\\|ebh: ' \"$1\" || echo 'printed into the output'"
      ${EBH_BIN} ${EBH_PROCESS_OUT}/closed_streams.h5)
  set_tests_properties(cli.process.closed_standard_streams PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
    "^exit status 0\nHDF\n$")
endif()

# A standard output that fails (/dev/full) once the output is written: one line that says the
# output file was written and what was printed is lost, exit status 1, never a crash.
if(EBH_GATE_BASH AND EXISTS /dev/full)
  add_test(NAME cli.process.stdout_full
    COMMAND ${EBH_GATE_BASH} -c
      "rm -f \"$1\"; err=$(\"$0\" replay tube tube_insert -o \"$1\" --duration 0.1 2>&1 >/dev/full); rc=$?; printf '%s\\n' \"$err\" | grep -v '^ebh: warning: '; echo \"exit status $rc\"; [ -s \"$1\" ] && echo written"
      ${EBH_BIN} ${EBH_PROCESS_OUT}/stdout_full.h5)
  set_tests_properties(cli.process.stdout_full PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
    "^ebh: error: standard output: No space left on device \\(the output file was written; what the command printed is lost\\)\nexit status 1\nwritten\n$")
endif()

# A pipe's reader gone before the command prints (`| head`, here a reader that has already ended)
# ended it by SIGPIPE at its first line, before the plot it was asked for was written: the files
# are written, the exit status is 128 + SIGPIPE, without a word.
if(EBH_GATE_BASH)
  add_test(NAME cli.process.stdout_reader_gone
    COMMAND ${EBH_GATE_BASH} -c
      "rm -f \"$1\"; exec 4> >(true); wait $!; \"$0\" bench sizes --scene tube --levels 0 --seconds 0.05 --plot \"$1\" >&4 2>\"$1.err\"; rc=$?; [ $rc = $((128 + $(kill -l PIPE))) ] && rc='128 + SIGPIPE'; echo \"exit status $rc\"; grep -v '^ebh: warning: ' \"$1.err\"; [ -s \"$1\" ] && echo plotted"
      ${EBH_BIN} ${EBH_PROCESS_OUT}/reader_gone.png)
  set_tests_properties(cli.process.stdout_reader_gone PROPERTIES LABELS cli TIMEOUT 120 PASS_REGULAR_EXPRESSION
    "^exit status 128 \\+ SIGPIPE\nplotted\n$")
endif()

# GALLIUM_DRIVER naming a renderer OSMesa cannot run here crashed Mesa while it created the
# context; it is refused before any work. OSMesa's own renderers run.
if(EBH_HAVE_OSMESA)
  add_test(NAME cli.process.gallium_driver_unknown
    COMMAND ${CMAKE_COMMAND}
      "-DCMD=${EBH_BIN};render;${EBH_RENDER_OUT}/tube.h5;-o;${EBH_PROCESS_OUT}/gallium_frames;--size;64x64"
      "-DEXPECT=^ebh: error: GALLIUM_DRIVER 'bogus': not a renderer OSMesa runs here \\(llvmpipe or softpipe; unset it for Mesa's default\\)\n$"
      -DSTATUS=1 -P ${EBH_EXPECT_ERROR})
  set_tests_properties(cli.process.gallium_driver_unknown PROPERTIES FIXTURES_REQUIRED render_tube
    LABELS "cli;render" ENVIRONMENT GALLIUM_DRIVER=bogus)
  add_test(NAME cli.process.gallium_driver_softpipe
    COMMAND ${EBH_BIN} render ${EBH_RENDER_OUT}/tube.h5 -o ${EBH_PROCESS_OUT}/softpipe_frames --size 64x64 --every 50)
  set_tests_properties(cli.process.gallium_driver_softpipe PROPERTIES FIXTURES_REQUIRED render_tube
    LABELS "cli;render" ENVIRONMENT GALLIUM_DRIVER=softpipe)
endif()

# A processor-time limit (`ulimit -t`, soft and hard alike) ended the run by SIGKILL, its
# temporary left; it now stops by SIGXCPU before the hard limit: 128 + SIGXCPU, one line, no
# output nor temporary.
if(EBH_GATE_BASH)
  add_test(NAME cli.process.cpu_time_limit
    COMMAND ${EBH_GATE_BASH} -c
      "rm -rf \"$1\"; mkdir -p \"$1\"; (ulimit -t 4; exec \"$0\" replay tube tube_insert -o \"$1/out.h5\" -q --duration 10 2>\"$1/err\"); rc=$?; [ $rc = $((128 + $(kill -l XCPU))) ] && rc='128 + SIGXCPU'; echo \"exit status $rc\"; cat \"$1/err\"; ls -A \"$1\""
      ${EBH_BIN} ${EBH_PROCESS_OUT}/cpu_limit)
  set_tests_properties(cli.process.cpu_time_limit PROPERTIES LABELS cli TIMEOUT 60 PASS_REGULAR_EXPRESSION
    "^exit status 128 \\+ SIGXCPU\nebh: error: [^\n]*/out.h5: interrupted after [0-9.e+-]+ of 10 s; no output written\nerr\n$")
endif()

# Off a terminal (nohup, a Slurm job's log) a replay says how far it is, a line every
# --progress-every seconds of wall time; -q and the default's 60 s keep a short replay's log clean.
add_test(NAME cli.process.progress_lines
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_PROCESS_OUT}/progress.h5 --duration 0.3 --progress-every 0.001)
set_tests_properties(cli.process.progress_lines PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION
  "ebh: progress: 0\\.[0-9]+ of 0\\.30 s \\([0-9]+%\\) after [0-9]+ s, [0-9.]+x real time, \\|F\\| = [0-9.]+ N\n")
add_test(NAME cli.process.progress_quiet
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_PROCESS_OUT}/progress_quiet.h5 --duration 0.3 -q --progress-every 0.001)
add_test(NAME cli.process.progress_default
  COMMAND ${EBH_BIN} replay tube tube_insert -o ${EBH_PROCESS_OUT}/progress_default.h5 --duration 0.3)
set_tests_properties(cli.process.progress_quiet cli.process.progress_default PROPERTIES LABELS cli
  FAIL_REGULAR_EXPRESSION "progress:")
add_test(NAME cli.process.progress_batch
  COMMAND ${CMAKE_COMMAND} "-DCMD=${EBH_BIN};replay;--batch;${EBH_PROCESS_OUT}/no_batch.txt;--progress-every;5"
    "-DEXPECT=^ebh: error: --batch excludes --progress-every" -DSTATUS=1 -P ${EBH_EXPECT_ERROR})
set_tests_properties(cli.process.progress_batch PROPERTIES LABELS cli)

# A replay whose ticks' rows outgrow the memory it may use (`ulimit -v`; the rows stay in memory
# until the output is written whole) says so with the ticks, the size and what to do, not "out of
# memory": a 2000 s recording under 650 MB of address space (the scene and the recording take
# ~450 MB, the rows ~520 MB more).
if(EBH_GATE_BASH)
  add_test(NAME cli.process.long_replay_synth
    COMMAND ${EBH_GATE_BASH} -c "sed 's/t: 20.0,/t: 2000.0,/' \"$1\" > \"$2.yaml\" && exec \"$0\" synth \"$2.yaml\" -o \"$2\""
      ${EBH_BIN} ${EBH_IO_DATA}/tube_hold.yaml ${EBH_PROCESS_OUT}/long_hold.h5)
  add_test(NAME cli.process.long_replay_memory_limit
    COMMAND ${EBH_GATE_BASH} -c
      "rm -f \"$1\"; (ulimit -v 650000; exec \"$0\" replay tube \"$2\" -o \"$1\" -q); rc=$?; echo \"exit status $rc\"; [ -e \"$1\" ] && echo written; true"
      ${EBH_BIN} ${EBH_PROCESS_OUT}/long_out.h5 ${EBH_PROCESS_OUT}/long_hold.h5)
  set_tests_properties(cli.process.long_replay_synth PROPERTIES FIXTURES_SETUP long_hold LABELS cli)
  set_tests_properties(cli.process.long_replay_memory_limit PROPERTIES FIXTURES_REQUIRED long_hold LABELS cli TIMEOUT 120
    PASS_REGULAR_EXPRESSION "^ebh: error: [^\n]*/long_out.h5: out of memory for the replay's 2000001 ticks, kept in memory until the output is written whole \\(about 516 MB at ~258 bytes a tick\\): replay a window of the recording \\(--start, --duration\\), or give the process more memory \\(ulimit -v, the job's limit\\)\nexit status 1\n$")
endif()
# The same for an import of a million-row log under 320 MB (the program takes ~250 MB of address
# space before it reads a line): the samples read so far and what to do, not "out of memory".
if(EBH_GATE_BASH)
  add_test(NAME cli.process.import_memory_limit
    COMMAND ${EBH_GATE_BASH} -c
      "awk 'BEGIN { print \"t,x,y,z,qw,qx,qy,qz\"; for (i = 0; i < 1000000; i++) printf \"%.3f,0,0,0.03,1,0,0,0\\n\", i / 1000 }' > \"$1.csv\"; rm -f \"$1\"; (ulimit -v 320000; exec \"$0\" import \"$1.csv\" -o \"$1\"); rc=$?; rm -f \"$1.csv\"; echo \"exit status $rc\"; [ -e \"$1\" ] && echo written; true"
      ${EBH_BIN} ${EBH_PROCESS_OUT}/big_log.h5)
  set_tests_properties(cli.process.import_memory_limit PROPERTIES LABELS cli TIMEOUT 120 PASS_REGULAR_EXPRESSION
    "^ebh: error: [^\n]*/big_log.h5.csv: out of memory after reading [0-9]+ samples \\(~220 bytes each while importing\\): give the process more memory \\(ulimit -v, the job's limit\\), or import the log in parts\nexit status 1\n$")
endif()
