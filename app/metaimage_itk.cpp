#include "metaimage_itk.h"

#include <itkMetaImageIO.h>

#include <algorithm>
#include <iostream>
#include <sstream>

namespace handson::metaio {

namespace {

// MetaIO writes its complaints to std::cerr and std::cout: taken while alive.
class CaptureStreams {
 public:
  CaptureStreams() : err_(std::cerr.rdbuf(captured_.rdbuf())), out_(std::cout.rdbuf(captured_.rdbuf())) {}
  ~CaptureStreams() {
    std::cerr.rdbuf(err_);
    std::cout.rdbuf(out_);
  }
  std::string text() const {
    std::string s = captured_.str();
    std::replace(s.begin(), s.end(), '\n', ' ');
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
  }

 private:
  std::ostringstream captured_;
  std::streambuf* err_;
  std::streambuf* out_;
};

Component componentOf(itk::IOComponentEnum t) {
  switch (t) {
    case itk::IOComponentEnum::CHAR: return Component::Int8;
    case itk::IOComponentEnum::UCHAR: return Component::UInt8;
    case itk::IOComponentEnum::SHORT: return Component::Int16;
    case itk::IOComponentEnum::USHORT: return Component::UInt16;
    case itk::IOComponentEnum::INT: return Component::Int32;
    case itk::IOComponentEnum::UINT: return Component::UInt32;
    case itk::IOComponentEnum::LONG:
    case itk::IOComponentEnum::LONGLONG: return Component::Int64;
    case itk::IOComponentEnum::ULONG:
    case itk::IOComponentEnum::ULONGLONG: return Component::UInt64;
    case itk::IOComponentEnum::FLOAT: return Component::Float32;
    case itk::IOComponentEnum::DOUBLE: return Component::Float64;
    default: return Component::Other;
  }
}

std::string withCapture(const std::string& what, const std::string& captured) { return captured.empty() ? what : what + " (" + captured + ")"; }

}  // namespace

bool readHeader(const std::string& path, Header& h, std::string& error) {
  CaptureStreams capture;
  auto io = itk::MetaImageIO::New();
  io->SetFileName(path);
  try {
    if (!io->CanReadFile(path.c_str())) {
      error = withCapture("not a MetaImage file", capture.text());
      return false;
    }
    io->ReadImageInformation();
    h.dimensions = io->GetNumberOfDimensions();
    h.components = io->GetNumberOfComponents();
    h.component = componentOf(io->GetComponentType());
    h.componentBytes = h.component == Component::Other ? 0 : io->GetComponentSize();  // (throws on an unknown type)
    for (unsigned d = 0; d < h.dimensions; ++d) {
      h.size.push_back(io->GetDimensions(d));
      h.spacing.push_back(io->GetSpacing(d));
      h.origin.push_back(io->GetOrigin(d));
      h.direction.push_back(io->GetDirection(d));
    }
  } catch (const std::exception& e) {  // itk::ExceptionObject and the standard ones ITK may let through
    error = withCapture(e.what(), capture.text());
    return false;
  }
  return true;
}

bool readData(const std::string& path, const Header& h, void* out, std::string& error) {
  CaptureStreams capture;
  auto io = itk::MetaImageIO::New();
  io->SetFileName(path);
  try {
    io->ReadImageInformation();
    if (io->GetNumberOfDimensions() != h.dimensions) {
      error = "the file changed while it was read";
      return false;
    }
    itk::ImageIORegion region(h.dimensions);  // the whole image (ImageIOBase reads nothing without one)
    for (unsigned d = 0; d < h.dimensions; ++d) {
      if (io->GetDimensions(d) != h.size[d]) {
        error = "the file changed while it was read";
        return false;
      }
      region.SetIndex(d, 0);
      region.SetSize(d, h.size[d]);
    }
    io->SetIORegion(region);
    const std::size_t said = capture.text().size();
    io->Read(out);
    // MetaIO reports short or undecodable data on its streams, not by an exception.
    if (capture.text().size() > said) {
      error = "its image data could not be read (" + capture.text().substr(said) + ")";
      return false;
    }
  } catch (const itk::ExceptionObject& e) {
    error = withCapture(e.GetDescription(), capture.text());
    return false;
  } catch (const std::exception& e) {
    error = withCapture(e.what(), capture.text());
    return false;
  }
  return true;
}

}  // namespace handson::metaio
