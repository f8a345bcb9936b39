// The session-script parser (app/session/session_script.h) on arbitrary text. A refusal is a
// handson::Error; anything else is a finding. A script that parses must format and parse again to
// the same events.
#include <cstdlib>
#include <string>

#include "app/session/session_script.h"
#include "sim/base/error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const handson::SessionScript s = handson::parseSessionScript(text, "fuzz");
    const handson::SessionScript again = handson::parseSessionScript(handson::formatSessionScript(s), "formatted");
    if (again.events.size() != s.events.size() || again.mode != s.mode || again.viewport.width != s.viewport.width) std::abort();
  } catch (const handson::Error&) {
  }
  return 0;
}
