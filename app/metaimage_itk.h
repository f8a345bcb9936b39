#pragma once
// The part of the MetaImage reader that talks to ITK (app/metaimage_itk.cpp), kept in a translation
// unit and a library of its own: ITK's headers bring ITK's bundled Eigen, which must not meet the
// Eigen the rest of the code uses, and Debian's ITK headers accept GCC only (the clang sanitizer
// build has no MetaImage support; HANDSON_HAVE_ITK tells). Plain types only.
#include <cstdint>
#include <string>
#include <vector>

namespace handson::metaio {

enum class Component { Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64, Other };

struct Header {
  unsigned dimensions = 0, components = 0;
  std::vector<std::uint64_t> size;             ///< per dimension
  std::vector<double> spacing, origin;         ///< per dimension (ITK's LPS)
  std::vector<std::vector<double>> direction;  ///< per dimension: its direction vector (LPS)
  Component component = Component::Other;
  std::size_t componentBytes = 0;
};

/// The header; `error` receives MetaIO's complaint and false is returned when it cannot be read.
bool readHeader(const std::string& path, Header& header, std::string& error);
/// The whole image's values (size x componentBytes bytes, file order) into `out`; false with the
/// reason in `error` when they cannot be read (short data included: MetaIO only prints that).
bool readData(const std::string& path, const Header& header, void* out, std::string& error);

}  // namespace handson::metaio
