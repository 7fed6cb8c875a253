# Runs CMD (a ;-list) and passes only when it exits 0 and every path in FILES (a ;-list) exists.
#   cmake -DCMD="a;b" -DFILES="x;y" -P expect_files.cmake
execute_process(COMMAND ${CMD} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "exit ${rc}\nstdout: ${out}\nstderr: ${err}")
endif()
foreach(f ${FILES})
  if(NOT EXISTS ${f})
    message(FATAL_ERROR "missing ${f}\nstdout: ${out}\nstderr: ${err}")
  endif()
endforeach()
message(STATUS "${out}")
