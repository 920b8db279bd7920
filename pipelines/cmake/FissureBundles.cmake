# fissure_add_bundle(): bake Fissure bundles as part of a game's CMake build.
#
#   include(path/to/fissure/pipelines/cmake/FissureBundles.cmake)   # or find_package(Fissure)
#   fissure_add_bundle(bunny
#     MESH    assets/bunny.obj                # relative to the current source folder
#     CAGE    assets/bunny-cage.node          # TetGen .node/.ele (both halves tracked), .msh, .mesh
#     # or, instead of CAGE, a cage made from the mesh (docs/cages.md):
#     # TETS 1000 [METHOD lattice|wrap]
#     OUTPUT  bundles/bunny.h5                # relative to the current binary folder
#     OPTIONS --wall-res 32 --skip collision  # any `fissure-bake bake` flags
#     [ALL])                                  # build it with the default target
#
# Makes a target NAME whose custom command re-bakes exactly when the mesh, the cage, the
# options or the fissure-bake executable changed, then verifies the result; the bundle
# appears only once both passed (a failed bake or verify leaves the previous one). The
# target's FISSURE_BUNDLE property holds the bundle's path, for install() or a
# POST_BUILD copy.
#
# The bake tool, first match wins: FISSURE_BAKE_EXECUTABLE (a cache path), the target
# `fissure-bake` when Fissure is built in the same project (add_subdirectory), or
# `fissure-bake` on the PATH.

include_guard(GLOBAL)
# The per-bundle bake script beside this file (CMAKE_CURRENT_LIST_DIR inside a function
# is the caller's folder, so it is kept here).
set(_FISSURE_BAKE_BUNDLE_SCRIPT "${CMAKE_CURRENT_LIST_DIR}/FissureBakeBundle.cmake")

function(_fissure_bake_tool out_command out_depends)
  if(FISSURE_BAKE_EXECUTABLE)
    set(${out_command} "${FISSURE_BAKE_EXECUTABLE}" PARENT_SCOPE)
    set(${out_depends} "${FISSURE_BAKE_EXECUTABLE}" PARENT_SCOPE)
  elseif(TARGET fissure-bake)
    set(${out_command} "$<TARGET_FILE:fissure-bake>" PARENT_SCOPE)
    set(${out_depends} fissure-bake "$<TARGET_FILE:fissure-bake>" PARENT_SCOPE)
  else()
    find_program(FISSURE_BAKE_EXECUTABLE fissure-bake DOC "The fissure-bake tool")
    if(NOT FISSURE_BAKE_EXECUTABLE)
      message(FATAL_ERROR "fissure_add_bundle: fissure-bake not found. Set FISSURE_BAKE_EXECUTABLE to its path, "
                          "put it on the PATH, or add Fissure to the project with add_subdirectory().")
    endif()
    set(${out_command} "${FISSURE_BAKE_EXECUTABLE}" PARENT_SCOPE)
    set(${out_depends} "${FISSURE_BAKE_EXECUTABLE}" PARENT_SCOPE)
  endif()
endfunction()

# The cage file given (absolute) and the files the bake reads for it: both halves of a
# TetGen pair, so both are dependencies.
function(_fissure_cage_files out_cage out_files)
  cmake_path(ABSOLUTE_PATH ARG_CAGE BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" NORMALIZE OUTPUT_VARIABLE cage)
  if(NOT EXISTS "${cage}")
    message(FATAL_ERROR "fissure_add_bundle(${name}): cage ${cage} does not exist")
  endif()
  set(files "${cage}")
  cmake_path(GET cage EXTENSION LAST_ONLY extension)
  string(TOLOWER "${extension}" extension)
  if(extension STREQUAL ".node" OR extension STREQUAL ".ele")
    cmake_path(REPLACE_EXTENSION cage LAST_ONLY ".node" OUTPUT_VARIABLE node)
    cmake_path(REPLACE_EXTENSION cage LAST_ONLY ".ele" OUTPUT_VARIABLE ele)
    set(files "${node}" "${ele}")
  endif()
  set(${out_cage} "${cage}" PARENT_SCOPE)
  set(${out_files} "${files}" PARENT_SCOPE)
endfunction()

function(fissure_add_bundle name)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "ALL" "MESH;CAGE;TETS;METHOD;OUTPUT" "OPTIONS")
  foreach(required MESH OUTPUT)
    if(NOT ARG_${required})
      message(FATAL_ERROR "fissure_add_bundle(${name}): ${required} is required")
    endif()
  endforeach()
  if((ARG_CAGE AND ARG_TETS) OR (NOT ARG_CAGE AND NOT ARG_TETS))
    message(FATAL_ERROR "fissure_add_bundle(${name}): give CAGE (a cage file) or TETS (a cage made from the mesh), "
                        "one of them")
  endif()
  if(ARG_METHOD AND NOT ARG_TETS)
    message(FATAL_ERROR "fissure_add_bundle(${name}): METHOD chooses how TETS makes the cage; add TETS")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "fissure_add_bundle(${name}): unknown arguments ${ARG_UNPARSED_ARGUMENTS}; "
                        "bake flags go after OPTIONS")
  endif()

  cmake_path(ABSOLUTE_PATH ARG_MESH BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" NORMALIZE OUTPUT_VARIABLE mesh)
  cmake_path(ABSOLUTE_PATH ARG_OUTPUT BASE_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}" NORMALIZE OUTPUT_VARIABLE output)
  if(NOT EXISTS "${mesh}")
    message(FATAL_ERROR "fissure_add_bundle(${name}): mesh ${mesh} does not exist")
  endif()
  if(ARG_TETS)
    # A cage made from the mesh: the count and method are options like any other.
    set(cage_files "")
    set(cage_arguments "-DTETS=${ARG_TETS}")
    if(ARG_METHOD)
      list(APPEND cage_arguments "-DMETHOD=${ARG_METHOD}")
    endif()
    set(cage_name "an automatic cage of ${ARG_TETS} tets")
  else()
    _fissure_cage_files(cage cage_files)
    set(cage_arguments "-DCAGE=${cage}")
    cmake_path(GET cage FILENAME cage_name)
  endif()

  # OPTIONS "--wall-res 16" (one quoted string) is the flags of OPTIONS --wall-res 16.
  set(options "")
  foreach(option IN LISTS ARG_OPTIONS)
    separate_arguments(words UNIX_COMMAND "${option}")
    list(APPEND options ${words})
  endforeach()
  if(options MATCHES "[|]")
    message(FATAL_ERROR "fissure_add_bundle(${name}): OPTIONS cannot hold a | (${options})")
  endif()

  # The options live in a stamp file rewritten only when they change, so editing them
  # re-bakes under every generator (Make does not track command lines, Ninja does).
  set(stamp "${CMAKE_CURRENT_BINARY_DIR}/fissure-bundles/${name}.options")
  set(stamp_content "${options}")
  if(ARG_TETS)
    set(stamp_content "--tets ${ARG_TETS} --method ${ARG_METHOD} ${options}")
  endif()
  file(CONFIGURE OUTPUT "${stamp}" CONTENT "${stamp_content}\n")

  _fissure_bake_tool(bake bake_depends)
  # Baked to a temporary name, verified, then renamed (FissureBakeBundle.cmake): the
  # bundle is never half-made or unverified, and a failure keeps the previous one out of
  # date, so it runs again.
  string(REPLACE ";" "|" joined_options "${options}")
  cmake_path(GET mesh FILENAME mesh_name)
  add_custom_command(
    OUTPUT "${output}"
    COMMAND "${CMAKE_COMMAND}" "-DFISSURE_BAKE=${bake}" "-DMESH=${mesh}" ${cage_arguments} "-DOUTPUT=${output}"
            "-DOPTIONS=${joined_options}" -P "${_FISSURE_BAKE_BUNDLE_SCRIPT}"
    DEPENDS "${mesh}" ${cage_files} "${stamp}" ${bake_depends}
    COMMENT "Baking bundle ${name}: ${mesh_name} in ${cage_name}"
    VERBATIM)
  if(ARG_ALL)
    add_custom_target(${name} ALL DEPENDS "${output}")
  else()
    add_custom_target(${name} DEPENDS "${output}")
  endif()
  set_target_properties(${name} PROPERTIES FISSURE_BUNDLE "${output}")
endfunction()
