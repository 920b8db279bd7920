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

# The bake's custom command and target, shared by both kinds of cage.
macro(_fissure_add_bundle_target)
  if(ARG_ALL)
    add_custom_target(${name} ALL DEPENDS "${output}")
  else()
    add_custom_target(${name} DEPENDS "${output}")
  endif()
  set_target_properties(${name} PROPERTIES FISSURE_BUNDLE "${output}")
endmacro()

# fissure_add_bundle with TETS: the cage is made from the mesh by the bake; the count
# and method go into the options stamp, so changing either re-bakes.
function(_fissure_add_bundle_made_cage name)
  cmake_path(ABSOLUTE_PATH ARG_MESH BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" NORMALIZE OUTPUT_VARIABLE mesh)
  cmake_path(ABSOLUTE_PATH ARG_OUTPUT BASE_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}" NORMALIZE OUTPUT_VARIABLE output)
  if(NOT EXISTS "${mesh}")
    message(FATAL_ERROR "fissure_add_bundle(${name}): mesh ${mesh} does not exist")
  endif()
  set(cage_flags --tets "${ARG_TETS}")
  if(ARG_METHOD)
    list(APPEND cage_flags --method "${ARG_METHOD}")
  endif()
  set(stamp "${CMAKE_CURRENT_BINARY_DIR}/fissure-bundles/${name}.options")
  file(CONFIGURE OUTPUT "${stamp}" CONTENT "${cage_flags} ${ARG_OPTIONS}\n")
  _fissure_bake_tool(bake bake_depends)
  set(temporary "${output}.building.h5")
  cmake_path(GET output PARENT_PATH output_folder)
  cmake_path(GET mesh FILENAME mesh_name)
  add_custom_command(
    OUTPUT "${output}"
    COMMAND "${CMAKE_COMMAND}" -E make_directory "${output_folder}"
    COMMAND "${bake}" -q bake --mesh "${mesh}" ${cage_flags} -o "${temporary}" ${ARG_OPTIONS}
    COMMAND "${bake}" -q verify "${temporary}"
    COMMAND "${CMAKE_COMMAND}" -E rename "${temporary}" "${output}"
    DEPENDS "${mesh}" "${stamp}" ${bake_depends}
    COMMENT "Baking bundle ${name}: ${mesh_name} in an automatic cage of ${ARG_TETS} tets"
    VERBATIM)
  _fissure_add_bundle_target()
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
  if(ARG_TETS)
    _fissure_add_bundle_made_cage(${name})
    return()
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "fissure_add_bundle(${name}): unknown arguments ${ARG_UNPARSED_ARGUMENTS}; "
                        "bake flags go after OPTIONS")
  endif()

  cmake_path(ABSOLUTE_PATH ARG_MESH BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" NORMALIZE OUTPUT_VARIABLE mesh)
  cmake_path(ABSOLUTE_PATH ARG_CAGE BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" NORMALIZE OUTPUT_VARIABLE cage)
  cmake_path(ABSOLUTE_PATH ARG_OUTPUT BASE_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}" NORMALIZE OUTPUT_VARIABLE output)
  foreach(input mesh cage)
    if(NOT EXISTS "${${input}}")
      message(FATAL_ERROR "fissure_add_bundle(${name}): ${input} ${${input}} does not exist")
    endif()
  endforeach()

  # A TetGen cage is two files; the bake reads both, so both are dependencies.
  set(cage_files "${cage}")
  cmake_path(GET cage EXTENSION LAST_ONLY cage_extension)
  string(TOLOWER "${cage_extension}" cage_extension)
  if(cage_extension STREQUAL ".node" OR cage_extension STREQUAL ".ele")
    cmake_path(REPLACE_EXTENSION cage LAST_ONLY ".node" OUTPUT_VARIABLE node)
    cmake_path(REPLACE_EXTENSION cage LAST_ONLY ".ele" OUTPUT_VARIABLE ele)
    set(cage_files "${node}" "${ele}")
  endif()

  # The options live in a stamp file rewritten only when they change, so editing them
  # re-bakes under every generator (Make does not track command lines, Ninja does).
  set(stamp "${CMAKE_CURRENT_BINARY_DIR}/fissure-bundles/${name}.options")
  file(CONFIGURE OUTPUT "${stamp}" CONTENT "${ARG_OPTIONS}\n")

  _fissure_bake_tool(bake bake_depends)
  # Baked to a temporary name, verified, then renamed: the bundle is never half-made
  # or unverified, and a failure keeps the previous one out of date, so it runs again.
  set(temporary "${output}.building.h5")
  cmake_path(GET output PARENT_PATH output_folder)
  cmake_path(GET mesh FILENAME mesh_name)
  cmake_path(GET cage FILENAME cage_name)
  add_custom_command(
    OUTPUT "${output}"
    COMMAND "${CMAKE_COMMAND}" -E make_directory "${output_folder}"
    COMMAND "${bake}" -q bake --mesh "${mesh}" --cage "${cage}" -o "${temporary}" ${ARG_OPTIONS}
    COMMAND "${bake}" -q verify "${temporary}"
    COMMAND "${CMAKE_COMMAND}" -E rename "${temporary}" "${output}"
    DEPENDS "${mesh}" ${cage_files} "${stamp}" ${bake_depends}
    COMMENT "Baking bundle ${name}: ${mesh_name} in ${cage_name}"
    VERBATIM)
  _fissure_add_bundle_target()
endfunction()
