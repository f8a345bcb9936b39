# cmake -DIN=file -DOUT=header.h -DNAME=ident -P embed_text.cmake : a text file as a C++ raw string.
file(READ ${IN} content)
file(WRITE ${OUT} "// Generated from ${IN}. Do not edit.\n#pragma once\nnamespace handson {\ninline constexpr const char* ${NAME} = R\"handson_embed(${content})handson_embed\";\n}\n")
