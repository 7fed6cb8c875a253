# Runs CMD (a ;-list) and passes only when it exits 0, every path in FILES (a ;-list) exists and
# none in GONE (a ;-list) does.
#   cmake -DCMD="a;b" -DFILES="x;y" [-DGONE="z"] -P expect_files.cmake
execute_process(COMMAND ${CMD} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "exit ${rc}\nstdout: ${out}\nstderr: ${err}")
endif()
foreach(f ${FILES})
  if(NOT EXISTS ${f})
    message(FATAL_ERROR "missing ${f}\nstdout: ${out}\nstderr: ${err}")
  endif()
endforeach()
foreach(f ${GONE})
  if(EXISTS ${f})
    message(FATAL_ERROR "still there: ${f}\nstdout: ${out}\nstderr: ${err}")
  endif()
endforeach()
message(STATUS "${out}")
