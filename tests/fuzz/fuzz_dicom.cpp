// The DICOM series reader (app/io/dicom_io.h, through GDCM) on arbitrary bytes: the input is split at
// "\n--slice--\n" into up to eight files of one directory (so that series assembly — ordering,
// gaps, duplicates, mismatched slices — is reached, not only single-file parsing). A refusal is a
// handson::Error; anything else is a finding.
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "app/io/dicom_io.h"
#include "fuzz_input_file.h"
#include "sim/base/error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto dir = handson::fuzz::scratchDir() / "series";
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir);
  const std::string_view all(reinterpret_cast<const char*>(data), size), sep("\n--slice--\n");
  std::size_t start = 0;
  for (int k = 0; k < 8; ++k) {
    std::size_t end = all.find(sep, start);
    if (k == 7 || end == std::string_view::npos) end = all.size();
    handson::fuzz::writeFile(dir / ("slice" + std::to_string(k) + ".dcm"), data + start, end - start);
    if (end == all.size()) break;
    start = end + sep.size();
  }
  // First in a child process, as the app reads: an abort inside GDCM (Debian builds it with
  // assertions) is then a refused series, not a finding. Anything else is read again in this
  // process, where the fuzzer sees the coverage and the sanitizers see the memory.
  // HANDSON_FUZZ_DICOM_IN_PROCESS=1 skips the child: every GDCM abort is then reported (to collect
  // the inputs that the child process turns into refusals, for regression tests).
  static const bool inProcessOnly = std::getenv("HANDSON_FUZZ_DICOM_IN_PROCESS") != nullptr;
  if (!inProcessOnly) {
    try {
      handson::readDicomSeries(dir.string());
    } catch (const handson::DicomParserAborted& e) {
      if (e.signal() == SIGABRT) return 0;
    } catch (const handson::Error&) {
    }
  }
  try {
    const handson::Volume v = handson::readDicomSeriesInProcess(dir.string());
    v.geometry().validate();
  } catch (const handson::Error&) {
  }
  return 0;
}
