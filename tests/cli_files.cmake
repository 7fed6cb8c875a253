# Command-line tests of outputs that cannot be written: each is refused before any work, with one
# line naming the file, and leaves the previous output and the user's files as they were.
set(EBH_FILES_OUT ${PROJECT_BINARY_DIR}/cli_files)
file(MAKE_DIRECTORY ${EBH_FILES_OUT})
set(F ${EBH_FILES_OUT})
function(ebh_files_failure name expect)
  cmake_parse_arguments(ARG "" "OUTPUT" "KEEP;CMD" ${ARGN})
  set(extra)
  if(ARG_OUTPUT)
    list(APPEND extra -DOUTPUT=${ARG_OUTPUT})
  endif()
  add_test(NAME cli.files.${name}
    COMMAND ${CMAKE_COMMAND} "-DCMD=${ARG_CMD}" "-DEXPECT=${expect}" "-DKEEP=${ARG_KEEP}" -DSTATUS=1 -DNO_STDOUT=1
      ${extra} -P ${EBH_EXPECT_ERROR})
  set_tests_properties(cli.files.${name} PROPERTIES LABELS cli)
endfunction()

# A name longer than the file system allows (256 bytes) failed only when the finished replay was
# renamed into place.
string(REPEAT "a" 253 ebh_long_name)
ebh_files_failure(name_too_long
  "^ebh: error: [^\n]*/${ebh_long_name}.h5: cannot create the output: File name too long \\(a name of 256 bytes"
  OUTPUT ${F}/${ebh_long_name}.h5
  CMD ${EBH_BIN} replay tube tube_insert --duration 0.1 -q -o ${F}/${ebh_long_name}.h5)
