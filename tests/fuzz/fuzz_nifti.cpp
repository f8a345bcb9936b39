// The NIfTI reader (app/io/nifti_io.h) on arbitrary bytes: plain or gzip-compressed (told apart by
// the reader from the magic bytes), NIfTI-1 or -2. A refusal is a handson::Error; anything else is
// a finding. The volume read is checked for consistency with its own header. Each input is read as a
// single file (its first volume and its second, for 4D headers) and as both halves of a two-file
// .hdr/.img pair.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "app/io/nifti_io.h"
#include "fuzz_input_file.h"
#include "sim/base/error.h"

namespace {
void readChecked(const std::string& path, std::int64_t frame) {
  try {
    const handson::Volume v = handson::readNifti(path, handson::NiftiReadOptions{frame});
    if (v.voxelCount() != std::size_t(v.dims().x()) * std::size_t(v.dims().y()) * std::size_t(v.dims().z())) std::abort();
    v.geometry().validate();
  } catch (const handson::Error&) {
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto dir = handson::fuzz::scratchDir();
  handson::fuzz::writeFile(dir / "input.nii", data, size);
  readChecked((dir / "input.nii").string(), 0);
  readChecked((dir / "input.nii").string(), 1);
  handson::fuzz::writeFile(dir / "pair.hdr", data, size);
  handson::fuzz::writeFile(dir / "pair.img", data, size);
  readChecked((dir / "pair.hdr").string(), 0);
  return 0;
}
