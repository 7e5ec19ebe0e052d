# The compiler cache: CMAKE_CXX_COMPILER_LAUNCHER (unless given) and DELTA_CCACHE_LAUNCHER, the
# same command for makefiles (Verilator's OBJCACHE). Nothing without ccache.
#
# base_dir is the tree (DELTA_CCACHE_BASE_DIR, default the project's source folder): a clone in
# another folder hashes its paths (-I, the source file) as the first build did, so every
# translation unit is a hit. The build folders are inside it (build/, build/host-only, build-fuzz/).
# DELTA_CCACHE_ENV adds settings (the fuzz tree's -g objects: CCACHE_NOHASHDIR=1).
find_program(DELTA_CCACHE ccache)
set(DELTA_CCACHE_LAUNCHER "")
if(DELTA_CCACHE)
  if(NOT DEFINED DELTA_CCACHE_BASE_DIR)
    set(DELTA_CCACHE_BASE_DIR ${PROJECT_SOURCE_DIR})
  endif()
  set(DELTA_CCACHE_LAUNCHER /usr/bin/env CCACHE_BASEDIR=${DELTA_CCACHE_BASE_DIR} ${DELTA_CCACHE_ENV} ${DELTA_CCACHE})
  if(NOT DEFINED CMAKE_CXX_COMPILER_LAUNCHER)
    set(CMAKE_CXX_COMPILER_LAUNCHER ${DELTA_CCACHE_LAUNCHER})
  endif()
endif()
