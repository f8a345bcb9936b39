# cmake -DSPV=in.spv -DHDR=out.h -DNAME=ident -P spirv_to_header.cmake
file(READ ${SPV} hex HEX)
string(LENGTH "${hex}" len)
math(EXPR rem "${len} % 8")
if(NOT rem EQUAL 0)
  message(FATAL_ERROR "${SPV}: size is not a multiple of 4 bytes")
endif()
# SPIR-V words are little endian in the file: bytes b0 b1 b2 b3 -> 0xb3b2b1b0.
string(REGEX REPLACE "([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])" "0x\\4\\3\\2\\1u," words "${hex}")
file(WRITE ${HDR} "// Generated from ${SPV}. Do not edit.\n#pragma once\n#include <cstdint>\nnamespace handson::shaders::spirv {\ninline constexpr std::uint32_t ${NAME}[] = {${words}};\n}\n")
