// The MetaImage reader (app/io/metaimage_io.h: MetaIO's header parser, our data reader) on arbitrary
// bytes: one-file images with raw or compressed data, their first volume and their second (a fourth
// axis or channels). A refusal is a handson::Error; anything else is a finding. The volume read is
// checked against its own geometry.
#include <cstdint>
#include <cstdlib>

#include "app/io/metaimage_io.h"
#include "fuzz_input_file.h"
#include "sim/base/error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = handson::fuzz::scratchDir() / "input.mha";
  handson::fuzz::writeFile(path, data, size);
  for (std::int64_t frame : {0, 1}) {
    try {
      const handson::Volume v = handson::readMetaImage(path.string(), frame);
      if (v.voxelCount() != std::size_t(v.dims().x()) * std::size_t(v.dims().y()) * std::size_t(v.dims().z())) std::abort();
      v.geometry().validate();
    } catch (const handson::Error&) {
    }
  }
  return 0;
}
