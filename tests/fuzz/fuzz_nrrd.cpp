// The NRRD reader (app/io/nrrd_io.h, Teem's nrrd library underneath) on arbitrary bytes: attached
// headers with every encoding Teem knows, its first volume and its second (list or time axes). A
// refusal is a handson::Error; anything else is a finding. The volume read is checked against its
// own geometry.
#include <cstdint>
#include <cstdlib>

#include "app/io/nrrd_io.h"
#include "fuzz_input_file.h"
#include "sim/base/error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = handson::fuzz::scratchDir() / "input.nrrd";
  handson::fuzz::writeFile(path, data, size);
  for (std::int64_t frame : {0, 1}) {
    try {
      const handson::Volume v = handson::readNrrd(path.string(), frame);
      if (v.voxelCount() != std::size_t(v.dims().x()) * std::size_t(v.dims().y()) * std::size_t(v.dims().z())) std::abort();
      v.geometry().validate();
    } catch (const handson::Error&) {
    }
  }
  return 0;
}
