# Assembles and zips one model's FMUs (run by the build: cmake -D... -P package_fmu.cmake).
# Layout: modelDescription.xml, binaries/<platform>/<identifier>.so (with grains_fork_guard.so and grains_snapshots.so
# beside it), resources/scene.toml (and its particles.file, at the same path relative to it),
# documentation/index.html, extra/org.fmi-standard.fmi-ls-ref/ (reference results).
file(REMOVE_RECURSE ${STAGE})
execute_process(COMMAND ${DESCRIBE} ${SCENE} ${IDENTIFIER} ${STAGE}/generated ${VERSION} RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "grains_fmu_describe failed for ${SCENE}")
endif()
# The files the scene reads besides itself (its particles.file), and the depfile that rebuilds the FMUs when they change
file(READ ${STAGE}/generated/resources.txt particle_file)
get_filename_component(scene_dir ${SCENE} DIRECTORY)
set(depends "")
if(particle_file)
  set(depends "${scene_dir}/${particle_file}")
endif()
# Make's syntax: a space, '#' or '$' in a path escaped (a folder with a space made a dependency that never exists, and
# the FMU was packaged again at every build)
set(depfile_line "${OUT}/fmi2/${MODEL}.fmu|${OUT}/fmi3/${MODEL}.fmu:|${depends}")
string(REPLACE "$" "$$" depfile_line "${depfile_line}")
string(REPLACE "#" "\\#" depfile_line "${depfile_line}")
string(REPLACE " " "\\ " depfile_line "${depfile_line}")
string(REPLACE "|" " " depfile_line "${depfile_line}")
file(WRITE ${STAGE}.d "${depfile_line}\n")
foreach(version 2 3)
  if(version EQUAL 2)
    set(platform linux64)
  else()
    set(platform x86_64-linux)
  endif()
  set(root ${STAGE}/fmi${version})
  file(MAKE_DIRECTORY ${root}/binaries/${platform} ${root}/resources)
  file(COPY_FILE ${STAGE}/generated/fmi${version}/modelDescription.xml ${root}/modelDescription.xml)
  file(COPY_FILE ${BINARY} ${root}/binaries/${platform}/${IDENTIFIER}.so)
  file(COPY_FILE ${PLUGIN} ${root}/binaries/${platform}/grains_snapshots.so)   # optional HDF5 snapshots
  file(COPY_FILE ${FORK_GUARD} ${root}/binaries/${platform}/grains_fork_guard.so)   # the fork handler that stays loaded
  file(COPY_FILE ${SCENE} ${root}/resources/scene.toml)
  if(particle_file)
    get_filename_component(particle_dir ${root}/resources/${particle_file} DIRECTORY)
    file(MAKE_DIRECTORY ${particle_dir})
    file(COPY_FILE ${scene_dir}/${particle_file} ${root}/resources/${particle_file})
  endif()
  file(COPY ${STAGE}/generated/documentation ${STAGE}/generated/extra DESTINATION ${root})
  file(MAKE_DIRECTORY ${OUT}/fmi${version})
  execute_process(COMMAND ${CMAKE_COMMAND} -E tar cf ${OUT}/fmi${version}/${MODEL}.fmu --format=zip
                          modelDescription.xml binaries resources documentation extra
                  WORKING_DIRECTORY ${root} RESULT_VARIABLE failed)
  if(failed)
    message(FATAL_ERROR "zipping ${OUT}/fmi${version}/${MODEL}.fmu failed")
  endif()
endforeach()
