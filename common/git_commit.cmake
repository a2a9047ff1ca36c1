# Writes OUTPUT, a C++ file defining plumage::git_commit() (common/build_info.h), from the git
# state of SOURCE_DIR. Run at every build (common/CMakeLists.txt); file(CONFIGURE) rewrites
# OUTPUT only when the answer changed, so an unchanged tree recompiles and relinks nothing.
#   cmake -DGIT_EXECUTABLE=... -DSOURCE_DIR=... -DOUTPUT=... -P git_commit.cmake
#
# --no-optional-locks: a build must never hold .git/index.lock, or a `git add` or `git commit`
# running meanwhile in the same checkout would fail. (`git describe --dirty` refreshes the
# index under that lock, so "dirty" is asked of `git status` instead, which then does not.)
set(commit "unknown")
if(GIT_EXECUTABLE)
  execute_process(COMMAND "${GIT_EXECUTABLE}" --no-optional-locks rev-parse --show-toplevel
                  WORKING_DIRECTORY "${SOURCE_DIR}" RESULT_VARIABLE status
                  OUTPUT_VARIABLE top OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(status EQUAL 0 AND top)
    # Sources unpacked inside some other repository are not a checkout of their own.
    file(REAL_PATH "${top}" top)
    file(REAL_PATH "${SOURCE_DIR}" source)
    if(top STREQUAL source)
      execute_process(COMMAND "${GIT_EXECUTABLE}" --no-optional-locks describe --always
                      WORKING_DIRECTORY "${SOURCE_DIR}" RESULT_VARIABLE status
                      OUTPUT_VARIABLE described OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
      if(status EQUAL 0 AND described)
        set(commit "${described}")
        execute_process(COMMAND "${GIT_EXECUTABLE}" --no-optional-locks status --porcelain
                                --untracked-files=no
                        WORKING_DIRECTORY "${SOURCE_DIR}" RESULT_VARIABLE status
                        OUTPUT_VARIABLE changes OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
        if(NOT status EQUAL 0 OR changes)
          # Which edits: two builds of different uncommitted changes to one commit must not
          # share a name (checkpoints are keyed by it: virtual_gonio/goniometer.h), so the
          # name carries a hash of the tracked files' diff against the commit.
          execute_process(COMMAND "${GIT_EXECUTABLE}" --no-optional-locks diff HEAD --no-ext-diff
                                  --binary
                          WORKING_DIRECTORY "${SOURCE_DIR}" OUTPUT_VARIABLE diff ERROR_QUIET)
          string(SHA1 diff_hash "${diff}")
          string(SUBSTRING "${diff_hash}" 0 12 diff_hash)
          string(APPEND commit "-dirty-${diff_hash}")
        endif()
      endif()
    endif()
  endif()
endif()
file(CONFIGURE OUTPUT "${OUTPUT}" @ONLY CONTENT [[
// Generated at build time by common/git_commit.cmake.
#include "common/build_info.h"

std::string_view plumage::git_commit() { return "@commit@"; }
]])
