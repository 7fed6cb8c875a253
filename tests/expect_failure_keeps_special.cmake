# expect_failure.cmake, and afterwards each of PIPES (a ;-list) is still a named pipe and each of
# LINKS still a symbolic link: files a failed run must neither delete nor replace, and which
# KEEP cannot hash (reading a named pipe waits for a writer).
#   cmake -DCMD=... -DEXPECT=... [-DPIPES="p1;p2"] [-DLINKS="l1;l2"] [expect_failure.cmake's options] -P expect_failure_keeps_special.cmake
include(${CMAKE_CURRENT_LIST_DIR}/expect_failure.cmake)
foreach(p IN LISTS PIPES)
  execute_process(COMMAND test -p ${p} RESULT_VARIABLE is_pipe)
  if(NOT is_pipe EQUAL 0)
    message(FATAL_ERROR "${p} is no longer a named pipe")
  endif()
endforeach()
foreach(l IN LISTS LINKS)
  if(NOT IS_SYMLINK ${l})
    message(FATAL_ERROR "${l} is no longer a symbolic link")
  endif()
endforeach()
