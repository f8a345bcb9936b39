# The core build (HANDSON_CORE_ONLY: sim/ and interaction/ with their tests) configures on a machine
# without Vulkan, SDL2, GDCM, libpng, zlib, JSON or glslc: it is configured here with every one of
# those packages disabled (CMake refuses a REQUIRED find_package of a disabled package, so any search
# for one fails the configure), and sim/ and interaction/ must include none of their headers nor any
# header of the folders above them.
#
#   cmake -DSOURCE=<repo> -DBINARY=<scratch dir> -DGENERATOR=<generator> -P check_core_only.cmake
foreach(var SOURCE BINARY GENERATOR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_core_only.cmake needs -D${var}=...")
  endif()
endforeach()

set(upper_headers "#include [<\"](vulkan/|SDL|gdcm|png\\.h|zlib\\.h|nlohmann/|imgui|render/|app/|shaders/)")
foreach(folder sim interaction)
  file(GLOB sources ${SOURCE}/${folder}/*.h ${SOURCE}/${folder}/*.cpp)
  foreach(file IN LISTS sources)
    file(STRINGS ${file} hits REGEX "${upper_headers}")
    if(hits)
      message(FATAL_ERROR "${file} includes what the core build does not have: ${hits}")
    endif()
  endforeach()
endforeach()

file(REMOVE_RECURSE ${BINARY})
execute_process(
  COMMAND ${CMAKE_COMMAND} -S ${SOURCE} -B ${BINARY} -G ${GENERATOR} -DHANDSON_CORE_ONLY=ON
    -DCMAKE_DISABLE_FIND_PACKAGE_Vulkan=ON -DCMAKE_DISABLE_FIND_PACKAGE_SDL2=ON
    -DCMAKE_DISABLE_FIND_PACKAGE_GDCM=ON -DCMAKE_DISABLE_FIND_PACKAGE_PNG=ON
    -DCMAKE_DISABLE_FIND_PACKAGE_ZLIB=ON -DCMAKE_DISABLE_FIND_PACKAGE_nlohmann_json=ON
    -DCMAKE_DISABLE_FIND_PACKAGE_PkgConfig=ON
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the core build does not configure without Vulkan, SDL2, GDCM, libpng, zlib and JSON:\n${out}")
endif()
file(STRINGS ${BINARY}/CMakeCache.txt glslc REGEX "^GLSLC:")
if(glslc)
  message(FATAL_ERROR "the core build looked for glslc: ${glslc}")
endif()

execute_process(COMMAND ${CMAKE_COMMAND} --build ${BINARY} --target help
  RESULT_VARIABLE rc OUTPUT_VARIABLE targets ERROR_VARIABLE targets)
foreach(wanted handson_sim handson_interaction test_sim test_interaction)
  if(NOT targets MATCHES "(^|[\n ])${wanted}[:\n ]")
    message(FATAL_ERROR "the core build has no target ${wanted}:\n${targets}")
  endif()
endforeach()
foreach(unwanted handson_render handson_shaders handson_io handson_session handson_platform handson_tools handson_cli handson_bench handson
        test_render_cpu test_render_gpu test_io test_session test_tools test_cli test_bench test_window)
  if(targets MATCHES "(^|[\n ])${unwanted}[:\n ]")
    message(FATAL_ERROR "the core build has the target ${unwanted}, which needs more than the core")
  endif()
endforeach()
file(REMOVE_RECURSE ${BINARY})
message(STATUS "the core build configures without Vulkan, SDL2, GDCM, libpng, zlib, JSON and glslc")
