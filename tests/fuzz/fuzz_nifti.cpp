// The NIfTI reader (app/nifti_io.h) on arbitrary bytes: plain or gzip-compressed (told apart by
// the reader from the magic bytes), NIfTI-1 or -2. A refusal is a handson::Error; anything else is
// a finding. The volume read is checked for consistency with its own header.
#include <cstdlib>

#include "app/nifti_io.h"
#include "fuzz_input_file.h"
#include "sim/error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = handson::fuzz::scratchDir() / "input.nii";
  handson::fuzz::writeFile(path, data, size);
  try {
    const handson::Volume v = handson::readNifti(path.string());
    if (v.voxelCount() != std::size_t(v.dims().x()) * std::size_t(v.dims().y()) * std::size_t(v.dims().z())) std::abort();
    v.geometry().validate();
  } catch (const handson::Error&) {
  }
  return 0;
}
