# Fixture of the cli.safety tests (tests/cli.cmake): fresh copies of the inputs they must leave
# as they were, a link to one, a recording whose last time is 1e300 s and an unfinished output.
#   cmake -DSAFE=dir -DSRC=source_dir -DEBH=ebh -P safety_setup.cmake
file(GLOB leftovers ${SAFE}/.*.ebh-partial)
if(leftovers)
  file(REMOVE ${leftovers})
endif()
file(COPY_FILE ${SRC}/recordings/tube_insert.h5 ${SAFE}/rec.h5)
foreach(kind replay synth import)
  file(COPY_FILE ${SRC}/recordings/tube_insert.h5 ${SAFE}/previous_${kind}.h5)
endforeach()
file(COPY_FILE ${SRC}/recordings/tube_insert.yaml ${SAFE}/plan.yaml)
file(COPY_FILE ${SRC}/tests/data/io/sample.csv ${SAFE}/log.csv)
file(COPY_FILE ${SRC}/scenarios/tube.msh ${SAFE}/tube.msh)
file(COPY_FILE ${SAFE}/scene.yaml.in ${SAFE}/scene.yaml)
file(REMOVE ${SAFE}/link.h5)
file(CREATE_LINK rec.h5 ${SAFE}/link.h5 SYMBOLIC)
file(WRITE ${SAFE}/.unfinished.h5.host.1.ebh-partial "unfinished")
execute_process(COMMAND ${EBH} import ${SAFE}/endless.csv -o ${SAFE}/endless.h5 --scene tube
  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cannot make endless.h5: ${err}")
endif()
