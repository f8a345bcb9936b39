# Compiles GLSL compute shaders with glslc into the build tree and embeds the SPIR-V as C++ arrays
# (generated headers, never committed), so binaries read no shader files at run time.
#
#   handson_compile_shaders(OUT_HEADERS <var> SOURCES a.comp b.comp DEPENDS common.glsl shared.h)
function(handson_compile_shaders)
  cmake_parse_arguments(ARG "" "OUT_HEADERS" "SOURCES;DEPENDS" ${ARGN})
  set(headers)
  foreach(src IN LISTS ARG_SOURCES)
    get_filename_component(name ${src} NAME_WE)
    set(abs ${CMAKE_CURRENT_SOURCE_DIR}/${src})
    set(spv ${CMAKE_CURRENT_BINARY_DIR}/spirv/${name}.spv)
    set(hdr ${CMAKE_CURRENT_BINARY_DIR}/spirv/${name}.spv.h)
    set(deps)
    foreach(d IN LISTS ARG_DEPENDS)
      list(APPEND deps ${CMAKE_CURRENT_SOURCE_DIR}/${d})
    endforeach()
    add_custom_command(
      OUTPUT ${hdr}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_CURRENT_BINARY_DIR}/spirv
      COMMAND ${GLSLC} --target-env=vulkan1.2 -O -Werror -I${CMAKE_CURRENT_SOURCE_DIR} ${abs} -o ${spv}
      COMMAND ${CMAKE_COMMAND} -DSPV=${spv} -DHDR=${hdr} -DNAME=${name} -P ${PROJECT_SOURCE_DIR}/cmake/spirv_to_header.cmake
      DEPENDS ${abs} ${deps} ${PROJECT_SOURCE_DIR}/cmake/spirv_to_header.cmake
      COMMENT "glslc ${src}"
      VERBATIM)
    list(APPEND headers ${hdr})
  endforeach()
  set(${ARG_OUT_HEADERS} ${headers} PARENT_SCOPE)
endfunction()
