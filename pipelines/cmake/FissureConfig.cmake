# find_package(Fissure) for projects that bake bundles: provides fissure_add_bundle()
# (FissureBundles.cmake) and finds the fissure-bake installed beside this file
# (<prefix>/lib/cmake/Fissure → <prefix>/bin), unless FISSURE_BAKE_EXECUTABLE is set.
include_guard(GLOBAL)
if(NOT FISSURE_BAKE_EXECUTABLE)
  find_program(FISSURE_BAKE_EXECUTABLE fissure-bake
    HINTS "${CMAKE_CURRENT_LIST_DIR}/../../../bin" NO_DEFAULT_PATH DOC "The fissure-bake tool")
endif()
include("${CMAKE_CURRENT_LIST_DIR}/FissureBundles.cmake")
set(Fissure_FOUND TRUE)
