# Command-line tests of outputs that cannot be written: each is refused before any work, with one
# line naming the file, and leaves the previous output and the user's files as they were.
set(EBH_FILES_OUT ${PROJECT_BINARY_DIR}/cli_files)
file(MAKE_DIRECTORY ${EBH_FILES_OUT})
set(F ${EBH_FILES_OUT})
# ebh_files_failure(NAME EXPECT [OUTPUT file] [KEEP files] [PIPES pipes] [LINKS links] CMD ...):
# cli.cmake's ebh_expect_failure with nothing on stdout, after this file's setup.
function(ebh_files_failure name expect)
  ebh_expect_failure(cli.files.${name} files "${expect}" NO_STDOUT ${ARGN})
endfunction()
string(REPEAT "a" 253 ebh_long_name)  # 256 bytes with .h5: one more than a name may hold
# Fresh previous outputs and the user's special files before each run.
set(ebh_rec ${PROJECT_SOURCE_DIR}/recordings/tube_insert.h5)
add_test(NAME cli.files.setup COMMAND sh -c
  "cd '${F}' && rm -rf ff.xdmf dv.xdmf && mkfifo ff.xdmf && ln -s /dev/null dv.xdmf && cp '${ebh_rec}' ff.h5 && cp '${ebh_rec}' dv.h5 && mkdir -p vframes && echo 'a frame' > vframes/frame_00000.png && cp '${ebh_rec}' ctx.h5 && cp '${ebh_rec}' fd.h5 && mkdir -p fdir/frame_00000.png && rm -rf store dl_replay.h5 dl_scene.yaml lk_nowhere.h5 lk_a.h5 lk_b.h5 && mkdir store && ln -s store/replay.h5 dl_replay.h5 && ln -s store/scene.yaml dl_scene.yaml && ln -s nowhere/run.h5 lk_nowhere.h5 && ln -s lk_b.h5 lk_a.h5 && ln -s lk_a.h5 lk_b.h5 && rm -rf rs_both.yaml rs_both.msh rs_self.yaml rs_self.msh rp_both.h5 rp_both.xdmf lk_long.h5 && ln -s rs_both.yaml rs_both.msh && ln -s rs_self.msh rs_self.yaml && ln -s rp_both.xdmf rp_both.h5 && ln -s 'store/${ebh_long_name}.h5' lk_long.h5")
set_tests_properties(cli.files.setup PROPERTIES FIXTURES_SETUP files LABELS cli)

# A name longer than the file system allows (256 bytes) failed only when the finished replay was
# renamed into place.
ebh_files_failure(name_too_long
  "^ebh: error: [^\n]*/${ebh_long_name}.h5: cannot create the output: File name too long \\(a name of 256 bytes"
  OUTPUT ${F}/${ebh_long_name}.h5
  CMD ${EBH_BIN} replay tube tube_insert --duration 0.1 -q -o ${F}/${ebh_long_name}.h5)

# The .xdmf index beside a replay with frames is an output too: a named pipe or a link to a device
# of that name was deleted, and the previous replay output replaced, when it was found only after
# the replay. Refused before any work, as a folder of that name is.
ebh_files_failure(index_is_a_pipe "^ebh: error: [^\n]*/ff.xdmf: a named pipe, not a regular file: "
  KEEP ${F}/ff.h5 PIPES ${F}/ff.xdmf
  CMD ${EBH_BIN} replay tube tube_insert --duration 0.1 --frames-hz 30 -q -o ${F}/ff.h5)
ebh_files_failure(index_links_to_a_device "^ebh: error: [^\n]*/dv.xdmf: a character device, not a regular file: "
  KEEP ${F}/dv.h5 LINKS ${F}/dv.xdmf
  CMD ${EBH_BIN} replay tube tube_insert --duration 0.1 --frames-hz 30 -q -o ${F}/dv.h5)

if(EBH_HAVE_OSMESA)
  # --video named like one of the frames, in their folder: the video replaced that frame. An
  # ffmpeg that writes text to its output file stands in for a real one (none may be installed).
  file(WRITE ${F}/ffmpeg.in "#!/bin/sh\nfor a; do out=$a; done\necho 'not a video' > \"$out\"\n")
  file(COPY ${F}/ffmpeg.in DESTINATION ${F}/bin FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ
    GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
  file(RENAME ${F}/bin/ffmpeg.in ${F}/bin/ffmpeg)
  ebh_files_failure(video_over_a_frame
    "^ebh: error: --video [^\n]*/vframes/frame_00000.png: named like a frame in [^\n]*/vframes, where the render writes"
    KEEP ${F}/vframes/frame_00000.png
    CMD ${EBH_BIN} render ${EBH_RENDER_OUT}/tube.h5 -o ${F}/vframes --size 32x24 -q --video ${F}/vframes/frame_00000.png)
  set_tests_properties(cli.files.video_over_a_frame PROPERTIES ENVIRONMENT "PATH=${F}/bin:/usr/bin:/bin"
    FIXTURES_REQUIRED "files;render_tube")
  # What can fail in the renderer's setup fails before the replay replaced the previous output: a
  # rendering context OSMesa cannot create (tests/render/no_osmesa_context.c stands in for Mesa out
  # of memory), and a folder named like a frame in --render's folder.
  add_library(ebh_no_osmesa_context MODULE ${CMAKE_CURRENT_SOURCE_DIR}/render/no_osmesa_context.c)
  ebh_files_failure(render_without_a_context
    "^ebh: error: --render [^\n]*/ctx_frames: OSMesa could not create a rendering context"
    KEEP ${F}/ctx.h5 OUTPUT ${F}/ctx.xdmf
    CMD env LD_PRELOAD=$<TARGET_FILE:ebh_no_osmesa_context> ASAN_OPTIONS=verify_asan_link_order=0
      ${EBH_BIN} replay tube tube_insert --duration 0.1 -q -o ${F}/ctx.h5 --render ${F}/ctx_frames)
  ebh_files_failure(render_folder_holds_a_folder_named_like_a_frame
    "^ebh: error: [^\n]*/fdir/frame_00000.png: named like a frame but a folder"
    KEEP ${F}/fd.h5 OUTPUT ${F}/fd.xdmf
    CMD ${EBH_BIN} replay tube tube_insert --duration 0.1 -q -o ${F}/fd.h5 --render ${F}/fdir)
endif()

# An output named by a link to nothing yet (a results folder of links into a data store): the file
# at the end of the link is created and the link stays (it was replaced by a regular file). Every
# command resolves its output there (io/atomic.hpp output_target): a replay and a scene init.
add_test(NAME cli.files.replay_through_a_link_to_nothing COMMAND sh -c
  "'${EBH_BIN}' replay tube tube_insert --duration 0.1 -q -o '${F}/dl_replay.h5' && test -L '${F}/dl_replay.h5' && test -s '${F}/store/replay.h5'")
add_test(NAME cli.files.scene_init_through_a_link_to_nothing COMMAND sh -c
  "'${EBH_BIN}' scene init '${PROJECT_SOURCE_DIR}/examples/own_data/organ.msh' -o '${F}/dl_scene.yaml' >/dev/null && test -L '${F}/dl_scene.yaml' && test -s '${F}/store/scene.yaml'")
# Paths inside the files written through a link are relative to where the files are (the link's
# target's folder), not to the link's: a mesh and a scene beside the links are named from the
# store, where the files are read (they named own.msh and my_scene.yaml, which the store lacks).
add_test(NAME cli.files.paths_inside_are_the_targets COMMAND sh -c
  "cd '${F}' && rm -rf own.msh my_scene.yaml my_rec.h5 store/own_scene.yaml store/own_rec.h5 && cp '${PROJECT_SOURCE_DIR}/examples/own_data/organ.msh' own.msh && ln -s store/own_scene.yaml my_scene.yaml && ln -s store/own_rec.h5 my_rec.h5 && '${EBH_BIN}' scene init own.msh -o my_scene.yaml >/dev/null && '${EBH_BIN}' scene info store/own_scene.yaml >/dev/null && '${EBH_BIN}' import '${PROJECT_SOURCE_DIR}/examples/own_data/touch_press.txt' -o my_rec.h5 --scene my_scene.yaml >/dev/null && '${EBH_BIN}' replay store/own_scene.yaml store/own_rec.h5 --duration 0.05 -q -o own_replay.h5")
set_tests_properties(cli.files.replay_through_a_link_to_nothing cli.files.scene_init_through_a_link_to_nothing
  cli.files.paths_inside_are_the_targets PROPERTIES FIXTURES_REQUIRED files LABELS cli)
set_tests_properties(cli.files.paths_inside_are_the_targets PROPERTIES FAIL_REGULAR_EXPRESSION "error|recorded for the scene")
# A link whose target's folder is missing, and a loop of links, are refused naming the link and its
# target, before any work; the links stay.
ebh_files_failure(link_to_a_missing_folder
  "^ebh: error: [^\n]*/lk_nowhere.h5: cannot create the output: a link to nowhere/run.h5, whose folder [^\n]*nowhere does not exist"
  LINKS ${F}/lk_nowhere.h5
  CMD ${EBH_BIN} replay tube tube_insert --duration 0.1 -q -o ${F}/lk_nowhere.h5)
ebh_files_failure(link_loop
  "^ebh: error: [^\n]*/lk_a.h5: cannot create the output: a link to lk_b.h5, whose links go round in a loop"
  LINKS ${F}/lk_a.h5 ${F}/lk_b.h5
  CMD ${EBH_BIN} import ${PROJECT_SOURCE_DIR}/examples/own_data/touch_press.txt -o ${F}/lk_a.h5)
# A scene refined or degraded through a link to nothing: its mesh goes beside the scene, at the
# link's target, not beside the link (the scene named new.msh, which its folder lacked), and the
# scene loads at the target and through the link. With -o DIR, a scene in DIR that is such a link
# takes its mesh along too.
add_test(NAME cli.files.scene_refine_through_a_link_to_nothing COMMAND sh -c
  "cd '${F}' && rm -rf rf_scene.yaml rf_scene.msh store/rf_scene.yaml store/rf_scene.msh && ln -s store/rf_scene.yaml rf_scene.yaml && '${EBH_BIN}' scene refine tube -o rf_scene.yaml >/dev/null && test -L rf_scene.yaml && test -s store/rf_scene.msh && ! test -e rf_scene.msh && ! test -L rf_scene.msh && '${EBH_BIN}' scene info store/rf_scene.yaml >/dev/null && '${EBH_BIN}' scene info rf_scene.yaml >/dev/null")
add_test(NAME cli.files.scene_degrade_through_a_link_to_nothing COMMAND sh -c
  "cd '${F}' && rm -rf dg_scene.yaml dg_scene.msh dgdir store/dg_scene.yaml store/dg_scene.msh store/tube_q0.1.yaml store/tube_q0.1.msh && ln -s store/dg_scene.yaml dg_scene.yaml && mkdir dgdir && ln -s ../store/tube_q0.1.yaml dgdir/tube_q0.1.yaml && '${EBH_BIN}' scene degrade tube --quality 0.1 -o dg_scene.yaml >/dev/null && '${EBH_BIN}' scene degrade tube --quality 0.1 -o dgdir >/dev/null && test -s store/dg_scene.msh && ! test -e dg_scene.msh && test -s store/tube_q0.1.msh && ! test -e dgdir/tube_q0.1.msh && '${EBH_BIN}' scene info store/dg_scene.yaml >/dev/null && '${EBH_BIN}' scene info dg_scene.yaml >/dev/null && '${EBH_BIN}' scene info dgdir/tube_q0.1.yaml >/dev/null")
set_tests_properties(cli.files.scene_refine_through_a_link_to_nothing cli.files.scene_degrade_through_a_link_to_nothing
  PROPERTIES FIXTURES_REQUIRED files LABELS "cli;scene")
# Two outputs of one command that are one file through a link to nothing (the mesh's name a link to
# the scene's, or the scene's to its mesh's; a replay's output a link to its XDMF index) were both
# written, the second over the first, or failed after the work: refused before any work, the
# link kept.
ebh_files_failure(refine_mesh_links_to_the_scene
  "^ebh: error: [^\n]*/rs_both.msh \\(a link to rs_both.yaml\\): is both the refined scene [^\n]*/rs_both.yaml and the refined mesh; choose another output file"
  OUTPUT ${F}/rs_both.yaml LINKS ${F}/rs_both.msh
  CMD ${EBH_BIN} scene refine tube -o ${F}/rs_both.yaml)
ebh_files_failure(refine_scene_links_to_its_mesh
  "^ebh: error: [^\n]*/rs_self.msh: is both the refined scene [^\n]*/rs_self.yaml \\(a link to rs_self.msh\\) and the refined mesh"
  OUTPUT ${F}/rs_self.msh LINKS ${F}/rs_self.yaml
  CMD ${EBH_BIN} scene refine tube -o ${F}/rs_self.yaml)
ebh_files_failure(replay_output_links_to_its_index
  "^ebh: error: [^\n]*/rp_both.xdmf: is both the replay output [^\n]*/rp_both.h5 \\(a link to rp_both.xdmf\\) and the replay's XDMF index"
  OUTPUT ${F}/rp_both.xdmf LINKS ${F}/rp_both.h5
  CMD ${EBH_BIN} replay tube tube_insert --duration 0.1 --frames-hz 30 -q -o ${F}/rp_both.h5)
# The name created through a link is its target's: a short link to a name longer than the file
# system allows is refused by that name's length, before any work.
ebh_files_failure(link_to_a_name_too_long
  "^ebh: error: [^\n]*/lk_long.h5: cannot create the output: File name too long \\(a name of 256 bytes at the end of its link, [^\n]*/store/a+\\.h5; this file system allows 255\\)"
  LINKS ${F}/lk_long.h5
  CMD ${EBH_BIN} import ${PROJECT_SOURCE_DIR}/examples/own_data/touch_press.txt -o ${F}/lk_long.h5)

# A folder no file can be created in is said as such: a replay blamed free space ("its folder's
# file system has 0 bytes free: free space, ...") before it tried to create its output.
ebh_files_failure(replay_into_proc
  "^ebh: error: /proc/run.h5: cannot create the output: No such file or directory \\(/proc is on a virtual file system"
  OUTPUT /proc/run.h5
  CMD ${EBH_BIN} replay tube tube_insert --duration 0.1 -q -o /proc/run.h5)
