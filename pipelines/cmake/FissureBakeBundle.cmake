# One bundle's bake, run by fissure_add_bundle()'s custom command (cmake -P), so the build
# log names the bundle, not the temporary it is baked under:
#   cmake -DFISSURE_BAKE=… -DMESH=… -DCAGE=… -DOUTPUT=… -DOPTIONS=a|b|c -P FissureBakeBundle.cmake
# or, for a cage made from the mesh, -DTETS=N [-DMETHOD=lattice|wrap] instead of -DCAGE.
# Bakes to OUTPUT.building.h5, verifies that file, then renames it onto OUTPUT. A bake or
# verify that fails prints the tool's messages as they are, removes the temporary, keeps
# the last good OUTPUT and fails (so the build fails and the bake runs again next time).
# OPTIONS: the bake flags, separated by | (a ; would split the -D argument).
cmake_minimum_required(VERSION 3.25)
foreach(required FISSURE_BAKE MESH OUTPUT)
  if(NOT DEFINED ${required})
    message(FATAL_ERROR "FissureBakeBundle.cmake: -D${required}=… is required")
  endif()
endforeach()
if(DEFINED TETS)
  set(cage_flags --tets "${TETS}")
  if(DEFINED METHOD)
    list(APPEND cage_flags --method "${METHOD}")
  endif()
elseif(DEFINED CAGE)
  set(cage_flags --cage "${CAGE}")
else()
  message(FATAL_ERROR "FissureBakeBundle.cmake: -DCAGE=… or -DTETS=… is required")
endif()
string(REPLACE "|" ";" options "${OPTIONS}")
set(temporary "${OUTPUT}.building.h5")
cmake_path(GET OUTPUT PARENT_PATH folder)
file(MAKE_DIRECTORY "${folder}")

# run(STEP ARGS...): the tool's output, with the temporary named as the bundle it becomes
# when all went well; as it is (naming the temporary) when the step failed.
function(run step)
  execute_process(COMMAND "${FISSURE_BAKE}" ${ARGN} RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT result EQUAL 0)
    file(REMOVE "${temporary}")
    string(STRIP "${err}${out}" text)
    message(FATAL_ERROR "${text}\nfissure: the ${step} of ${OUTPUT} failed (${result}); the last good bundle, if any, is kept")
  endif()
  string(REPLACE "${temporary}" "${OUTPUT}" out "${err}${out}")  # warnings came first
  string(STRIP "${out}" out)
  if(out)
    message(NOTICE "${out}")
  endif()
endfunction()

run(bake -q bake --mesh "${MESH}" ${cage_flags} -o "${temporary}" ${options})
run(verify -q verify "${temporary}")
file(RENAME "${temporary}" "${OUTPUT}")
