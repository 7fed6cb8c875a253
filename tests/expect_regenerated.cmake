# Runs a generator (CMD, a ;-list) that writes into NEW, then passes only when each of FILES in NEW
# is byte-identical to the committed one in OLD: committed generated files are what their
# generator makes.
#   cmake -DCMD="gen;dir" -DNEW=dir -DOLD=dir -DFILES="a;b" -P expect_regenerated.cmake
file(MAKE_DIRECTORY ${NEW})
execute_process(COMMAND ${CMD} RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the generator failed (${rc}): ${err}")
endif()
foreach(f IN LISTS FILES)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${NEW}/${f} ${OLD}/${f} RESULT_VARIABLE same)
  if(NOT same EQUAL 0)
    message(FATAL_ERROR "${OLD}/${f} differs from what the generator makes (${NEW}/${f}): regenerate and commit it")
  endif()
endforeach()
