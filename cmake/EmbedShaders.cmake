# Compiles GLSL compute shaders with glslc into the build tree and embeds the SPIR-V as C++ arrays
# (generated headers, never committed), so binaries read no shader files at run time. The files a
# shader includes are found by glslc itself (its -MD dependency file), so editing an include
# rebuilds exactly the shaders that use it.
#
#   handson_compile_shaders(OUT_HEADERS <var> SOURCES a.comp b.comp)
find_program(GLSLC glslc REQUIRED)

function(handson_compile_shaders)
  cmake_parse_arguments(ARG "" "OUT_HEADERS" "SOURCES" ${ARGN})
  set(headers)
  file(MAKE_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}/spirv)
  foreach(src IN LISTS ARG_SOURCES)
    get_filename_component(name ${src} NAME_WE)
    set(abs ${CMAKE_CURRENT_SOURCE_DIR}/${src})
    set(spv ${CMAKE_CURRENT_BINARY_DIR}/spirv/${name}.spv)
    set(dep ${CMAKE_CURRENT_BINARY_DIR}/spirv/${name}.spv.d)
    set(hdr ${CMAKE_CURRENT_BINARY_DIR}/spirv/${name}.spv.h)
    add_custom_command(
      OUTPUT ${spv}
      COMMAND ${GLSLC} --target-env=vulkan1.2 -O -Werror -I${CMAKE_CURRENT_SOURCE_DIR} -MD -MF ${dep} ${abs} -o ${spv}
      DEPENDS ${abs}
      DEPFILE ${dep}
      COMMENT "glslc ${src}"
      VERBATIM)
    add_custom_command(
      OUTPUT ${hdr}
      COMMAND ${CMAKE_COMMAND} -DSPV=${spv} -DHDR=${hdr} -DNAME=${name} -P ${PROJECT_SOURCE_DIR}/cmake/spirv_to_header.cmake
      DEPENDS ${spv} ${PROJECT_SOURCE_DIR}/cmake/spirv_to_header.cmake
      COMMENT "embedding ${name}.spv"
      VERBATIM)
    list(APPEND headers ${hdr})
  endforeach()
  set(${ARG_OUT_HEADERS} ${headers} PARENT_SCOPE)
endfunction()
