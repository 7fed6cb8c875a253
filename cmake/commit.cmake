# Writes OUT (ebh/commit.hpp) with the source tree's git commit, "-dirty" appended when tracked
# files differ from it, or "unknown" outside a git checkout. Run at every build (the ebh_commit
# target); the file is rewritten only when its text changes, so an unchanged commit rebuilds nothing.
execute_process(COMMAND git -C ${SOURCE_DIR} rev-parse HEAD
                OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc ERROR_QUIET)
if(NOT rc EQUAL 0 OR commit STREQUAL "")
  set(commit "unknown")
else()
  execute_process(COMMAND git -C ${SOURCE_DIR} status --porcelain --untracked-files=no
                  OUTPUT_VARIABLE changes OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(NOT changes STREQUAL "")
    set(commit "${commit}-dirty")
  endif()
endif()
set(text "#pragma once\n// Generated at build time by cmake/commit.cmake.\nnamespace ebh {\ninline constexpr const char* kGitCommit = \"${commit}\";\n}  // namespace ebh\n")
if(EXISTS ${OUT})
  file(READ ${OUT} old)
endif()
if(NOT old STREQUAL text)
  file(WRITE ${OUT} "${text}")
endif()
