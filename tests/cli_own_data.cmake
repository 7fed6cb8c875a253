# The own-data guide (docs/OWN_DATA.md) on its committed example (examples/own_data/): the files
# are what their generator makes; the guide's import, replay and metrics commands run and the tool
# presses into the organ; a log read in the wrong unit, or with a wrong tool transform, says so.
set(EBH_OWN ${PROJECT_SOURCE_DIR}/examples/own_data)
set(EBH_OWN_OUT ${PROJECT_BINARY_DIR}/cli_own_data)
file(MAKE_DIRECTORY ${EBH_OWN_OUT})
set(EBH_OWN_LOG ${EBH_OWN}/touch_press.txt)
set(EBH_OWN_SCENE ${EBH_OWN}/organ.yaml)
add_test(NAME cli.own_data.regenerated
  COMMAND ${CMAKE_COMMAND} "-DCMD=$<TARGET_FILE:make_own_data_example>;${EBH_OWN_OUT}/generated"
    -DNEW=${EBH_OWN_OUT}/generated -DOLD=${EBH_OWN} "-DFILES=organ.msh;touch_press.txt"
    -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_regenerated.cmake)
# The guide's commands, in order; none of them warns.
add_test(NAME cli.own_data.import
  COMMAND ${EBH_BIN} import ${EBH_OWN_LOG} -o ${EBH_OWN_OUT}/press.h5 --rate 1000 --unit cm
    --tool-transform 0,0,-4,180,0,0 --drop-repeats --scene ${EBH_OWN_SCENE})
set_tests_properties(cli.own_data.import PROPERTIES FIXTURES_SETUP own_data_recording FAIL_REGULAR_EXPRESSION "warning"
  PASS_REGULAR_EXPRESSION "press.h5: 1335 samples, 2 s, 1000 Hz, tool hook\n  dropped 666 samples that repeated")
add_test(NAME cli.own_data.replay
  COMMAND ${EBH_BIN} replay ${EBH_OWN_SCENE} ${EBH_OWN_OUT}/press.h5 -o ${EBH_OWN_OUT}/press_replay.h5)
set_tests_properties(cli.own_data.replay PROPERTIES FIXTURES_REQUIRED own_data_recording FIXTURES_SETUP own_data_replay
  FAIL_REGULAR_EXPRESSION "warning" PASS_REGULAR_EXPRESSION "2001 ticks, 201 physical steps.*peak force 1\\.[0-9]")
add_test(NAME cli.own_data.metrics COMMAND ${EBH_BIN} metrics ${EBH_OWN_OUT}/press_replay.h5 --json)
set_tests_properties(cli.own_data.metrics PROPERTIES FIXTURES_REQUIRED own_data_replay
  PASS_REGULAR_EXPRESSION "\"peak_force_N\": 1\\.[0-9].*\"contact_fraction\": 0\\.[1-9].*\"contact_warning\": null")
if(EBH_SYSTEM_PYTHON3 AND ebh_plot_deps EQUAL 0)
  add_test(NAME cli.own_data.plot
    COMMAND ${EBH_SYSTEM_PYTHON3} ${PROJECT_SOURCE_DIR}/scripts/plot_forces.py ${EBH_OWN_OUT}/press_replay.h5
      -o ${EBH_OWN_OUT}/press_forces.png)
  set_tests_properties(cli.own_data.plot PROPERTIES FIXTURES_REQUIRED own_data_replay PASS_REGULAR_EXPRESSION "press_forces.png")
endif()
# The organ with slivers (worst mean ratio 0.005): the stopping rule ends most steps on a stall far
# above the tolerance, and the replay says so.
add_test(NAME cli.own_data.degrade
  COMMAND ${EBH_BIN} scene degrade ${EBH_OWN_SCENE} --quality 0.005 --tets 100 -o ${EBH_OWN_OUT}/organ_sliver.yaml)
set_tests_properties(cli.own_data.degrade PROPERTIES FIXTURES_SETUP own_data_sliver)
add_test(NAME cli.own_data.sliver_steps_stall
  COMMAND ${EBH_BIN} replay ${EBH_OWN_OUT}/organ_sliver.yaml ${EBH_OWN_OUT}/press.h5 -o ${EBH_OWN_OUT}/sliver_replay.h5)
set_tests_properties(cli.own_data.sliver_steps_stall PROPERTIES FIXTURES_REQUIRED "own_data_recording;own_data_sliver"
  PASS_REGULAR_EXPRESSION "warning: .*sliver_replay.h5: [1-9][0-9]* of 201 physical steps stopped when their iterations stalled, with up to 0\\.[0-9]+ mesh weights unbalanced \\(more than 5 times solver.physical_tolerance")
# On it `chebyshev_rho: auto` is the relaxed Jacobi rate, 0.9986: warned at load.
add_test(NAME cli.own_data.sliver_auto_rho_warned
  COMMAND ${EBH_BIN} replay ${EBH_OWN_OUT}/organ_sliver.yaml ${EBH_OWN_OUT}/press.h5 -o ${EBH_OWN_OUT}/sliver_auto.h5
    --duration 0.05 --set solver.chebyshev_rho=auto)
set_tests_properties(cli.own_data.sliver_auto_rho_warned PROPERTIES FIXTURES_REQUIRED "own_data_recording;own_data_sliver"
  PASS_REGULAR_EXPRESSION "warning: --set 'solver.chebyshev_rho=auto': key 'solver.chebyshev_rho': Chebyshev's rho is 0\\.99[0-9]+ \\(auto: this mesh's relaxed Jacobi rate\\): so near 1 its weights \\(up to 1\\.[0-9]+\\)")
# The log read in mm (the default): the path is 1/66 of the organ's size; the fix is named.
add_test(NAME cli.own_data.wrong_unit
  COMMAND ${EBH_BIN} import ${EBH_OWN_LOG} -o ${EBH_OWN_OUT}/in_mm.h5 --rate 1000 --tool-transform 0,0,-4,180,0,0
    --drop-repeats --scene ${EBH_OWN_SCENE})
set_tests_properties(cli.own_data.wrong_unit PROPERTIES PASS_REGULAR_EXPRESSION
  "ebh: warning: .*touch_press.txt: the tool path spans 0.00231 m, 1/66 of the physical mesh's bounding-box diagonal \\(0.153 m\\); likely fix: --unit cm")
# The tip offset with the wrong sign: the tool stays 8 cm above the organ and never touches it.
add_test(NAME cli.own_data.import_wrong_offset
  COMMAND ${EBH_BIN} import ${EBH_OWN_LOG} -o ${EBH_OWN_OUT}/wrong_offset.h5 --rate 1000 --unit cm
    --tool-transform 0,0,4,180,0,0 --drop-repeats --scene ${EBH_OWN_SCENE})
set_tests_properties(cli.own_data.import_wrong_offset PROPERTIES FIXTURES_SETUP own_data_wrong_offset)
add_test(NAME cli.own_data.wrong_offset
  COMMAND ${EBH_BIN} replay ${EBH_OWN_SCENE} ${EBH_OWN_OUT}/wrong_offset.h5 -o ${EBH_OWN_OUT}/wrong_offset_replay.h5 -q)
set_tests_properties(cli.own_data.wrong_offset PROPERTIES FIXTURES_REQUIRED own_data_wrong_offset PASS_REGULAR_EXPRESSION
  "ebh: warning: .*wrong_offset_replay.h5: the tool never touched the tissue \\(no tick with contacts > 0\\): the path passes the tissue by; a tool tip offset \\(--tool-transform\\) or a world transform \\(--transform\\) that misplaces it\\?")
# No tool transform: the device's +z (toward the handle) taken for ebh's (toward the tip) puts
# the shaft down through the organ from the first tick.
add_test(NAME cli.own_data.import_unflipped
  COMMAND ${EBH_BIN} import ${EBH_OWN_LOG} -o ${EBH_OWN_OUT}/unflipped.h5 --rate 1000 --unit cm --drop-repeats)
set_tests_properties(cli.own_data.import_unflipped PROPERTIES FIXTURES_SETUP own_data_unflipped)
add_test(NAME cli.own_data.unflipped
  COMMAND ${EBH_BIN} replay ${EBH_OWN_SCENE} ${EBH_OWN_OUT}/unflipped.h5 -o ${EBH_OWN_OUT}/unflipped_replay.h5 -q)
set_tests_properties(cli.own_data.unflipped PROPERTIES FIXTURES_REQUIRED own_data_unflipped PASS_REGULAR_EXPRESSION
  "ebh: warning: .*unflipped_replay.h5: the physical tool starts inside the tissue \\(a virtual vertex [0-9.]+ mm inside its colliders at the first tick")
set_property(TEST cli.own_data.regenerated cli.own_data.import cli.own_data.replay cli.own_data.metrics
  cli.own_data.wrong_unit cli.own_data.import_wrong_offset cli.own_data.wrong_offset cli.own_data.import_unflipped
  cli.own_data.unflipped APPEND PROPERTY LABELS cli)
if(TEST cli.own_data.plot)
  set_property(TEST cli.own_data.plot APPEND PROPERTY LABELS cli)
endif()
