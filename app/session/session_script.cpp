#include "session_script.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "interaction/cut_stroke.h"
#include "interaction/gesture.h"
#include "sim/base/atomic_file.h"
#include "sim/base/error.h"
#include "sim/sim_scene.h"

namespace handson {

using nlohmann::json;

CameraState CameraState::from(const OrbitCamera& c) {
  CameraState s;
  s.target = c.target;
  s.distance = c.distance;
  s.azimuthDeg = glm::degrees(c.azimuth);
  s.elevationDeg = glm::degrees(c.elevation);
  s.rollDeg = glm::degrees(c.roll);
  s.fovDeg = glm::degrees(c.fovY);
  return s;
}

void CameraState::applyTo(OrbitCamera& c) const {
  c.target = target;
  c.distance = distance;
  c.azimuth = glm::radians(azimuthDeg);
  c.elevation = glm::radians(elevationDeg);
  c.roll = glm::radians(rollDeg);
  c.fovY = glm::radians(fovDeg);
}

namespace {

constexpr std::size_t kMaxEvents = 10'000'000;

struct Parser {
  std::string name;
  [[noreturn]] void fail(const std::string& what) const { throw Error(name + ": " + what); }

  const json& field(const json& obj, const char* key, const std::string& where) const {
    auto it = obj.find(key);
    if (it == obj.end()) fail(where + ": missing \"" + key + "\"");
    return *it;
  }
  double number(const json& v, const std::string& where, double lo = -1e12, double hi = 1e12) const {
    if (!v.is_number()) fail(where + " must be a number");
    const double x = v.get<double>();
    if (!std::isfinite(x) || x < lo || x > hi) fail(where + " is out of range");
    return x;
  }
  std::string string(const json& v, const std::string& where) const {
    if (!v.is_string()) fail(where + " must be a string");
    return v.get<std::string>();
  }
  glm::dvec3 vec3(const json& v, const std::string& where) const {
    if (!v.is_array() || v.size() != 3) fail(where + " must be an array of 3 numbers");
    return {number(v[0], where), number(v[1], where), number(v[2], where)};
  }
};

}  // namespace

SessionScript parseSessionScript(const std::string& text, const std::string& name) {
  Parser p{name};
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::exception& e) {  // parse errors, and numbers out of range (found by fuzzing)
    p.fail(std::string("not valid JSON (") + e.what() + ")");
  }
  if (!doc.is_object()) p.fail("the top level must be a JSON object");
  if (p.string(p.field(doc, "format", "top level"), "\"format\"") != "handson-session") p.fail("not a handson session script");
  SessionScript s;
  const json& ver = p.field(doc, "version", "top level");
  if (!ver.is_number_integer()) p.fail("\"version\" must be an integer");
  s.version = ver.get<int>();
  if (s.version < 1 || s.version > kSessionScriptVersion)
    p.fail("version " + std::to_string(s.version) + " is not supported (this build reads version " + std::to_string(kSessionScriptVersion) + ")");

  if (auto it = doc.find("volume"); it != doc.end()) {
    if (!it->is_object()) p.fail("\"volume\" must be an object");
    s.volumeSource = p.string(p.field(*it, "source", "volume"), "volume.source");
    if (s.volumeSource == "file") s.volumePath = p.string(p.field(*it, "path", "volume"), "volume.path");
    else if (s.volumeSource != "phantom") p.fail("volume.source must be \"phantom\" or \"file\"");
  }
  const json& vp = p.field(doc, "viewport", "top level");
  if (!vp.is_array() || vp.size() != 2) p.fail("\"viewport\" must be [width, height]");
  s.viewport.width = int(p.number(vp[0], "viewport width", 1, 16384));
  s.viewport.height = int(p.number(vp[1], "viewport height", 1, 16384));
  if (auto it = doc.find("preset"); it != doc.end()) s.preset = p.string(*it, "\"preset\"");
  if (auto it = doc.find("mode"); it != doc.end()) {
    s.mode = p.string(*it, "\"mode\"");
    InteractionMode m;
    if (!parseMode(s.mode, m)) p.fail("unknown mode \"" + s.mode + "\"");
  }
  if (auto it = doc.find("camera"); it != doc.end() && !it->is_null()) {
    if (!it->is_object()) p.fail("\"camera\" must be an object");
    CameraState c;
    c.target = p.vec3(p.field(*it, "target", "camera"), "camera.target");
    c.distance = p.number(p.field(*it, "distance", "camera"), "camera.distance", 1e-3, 1e7);
    c.azimuthDeg = p.number(p.field(*it, "azimuth_deg", "camera"), "camera.azimuth_deg");
    c.elevationDeg = p.number(p.field(*it, "elevation_deg", "camera"), "camera.elevation_deg", -89.0, 89.0);
    if (auto r = it->find("roll_deg"); r != it->end()) c.rollDeg = p.number(*r, "camera.roll_deg");
    if (auto f = it->find("fov_deg"); f != it->end()) c.fovDeg = p.number(*f, "camera.fov_deg", 1.0, 170.0);
    s.camera = c;
  }
  if (auto it = doc.find("free_area"); it != doc.end() && !it->is_null()) {
    if (!it->is_array() || it->size() != 4) p.fail("\"free_area\" must be [x0, y0, x1, y1]");
    ScreenArea a{p.number((*it)[0], "free_area x0", 0.0, 1.0), p.number((*it)[1], "free_area y0", 0.0, 1.0),
                 p.number((*it)[2], "free_area x1", 0.0, 1.0), p.number((*it)[3], "free_area y1", 0.0, 1.0)};
    if (!a.valid()) p.fail("\"free_area\" must be a rectangle of at least 5 % of the viewport each way");
    s.freeArea = a;
  }
  const json& events = p.field(doc, "events", "top level");
  if (!events.is_array()) p.fail("\"events\" must be an array");
  if (events.size() > kMaxEvents) p.fail("too many events");
  s.events.reserve(events.size());
  double last = 0.0;
  for (std::size_t i = 0; i < events.size(); ++i) {
    const json& e = events[i];
    const std::string where = "event " + std::to_string(i);
    if (!e.is_object()) p.fail(where + " must be an object");
    ScriptEvent ev;
    ev.t = p.number(p.field(e, "t", where), where + ".t", 0.0, 1e7);
    if (ev.t < last) p.fail(where + ": times must not decrease");
    last = ev.t;
    const bool touch = e.contains("touch"), ui = e.contains("ui");
    if (touch == ui) p.fail(where + ": needs exactly one of \"touch\" or \"ui\"");
    if (touch) {
      const std::string phase = p.string(e["touch"], where + ".touch");
      if (phase == "down") ev.touch.phase = TouchPhase::Down;
      else if (phase == "move") ev.touch.phase = TouchPhase::Move;
      else if (phase == "up") ev.touch.phase = TouchPhase::Up;
      else if (phase == "cancel") ev.touch.phase = TouchPhase::Cancel;
      else p.fail(where + ": unknown touch phase \"" + phase + "\"");
      const json& id = p.field(e, "id", where);
      if (!id.is_number_integer()) p.fail(where + ".id must be an integer");
      ev.touch.id = id.get<std::int64_t>();
      ev.touch.px = {p.number(p.field(e, "x", where), where + ".x"), p.number(p.field(e, "y", where), where + ".y")};
      if (auto pr = e.find("pressure"); pr != e.end()) ev.touch.pressure = p.number(*pr, where + ".pressure", 0.0, 1.0);
      ev.touch.time = ev.t;
    } else {
      ev.isTouch = false;
      const std::string actionName = p.string(e["ui"], where + ".ui");
      const auto action = parseUiAction(actionName);
      if (!action) p.fail(where + ": unknown UI action \"" + actionName + "\"");
      ev.action = *action;
      if (auto v = e.find("value"); v != e.end()) ev.value = p.string(*v, where + ".value");
      InteractionMode m;
      if (ev.action == UiAction::SetMode && !parseMode(ev.value, m)) p.fail(where + ": unknown mode \"" + ev.value + "\"");
      if (ev.action == UiAction::SetInterface && !parseInterface(ev.value))
        p.fail(where + ": the interface must be sliding or glued, not \"" + ev.value + "\"");
      if (ev.action == UiAction::Cut) try {
          parseCutQuads(ev.value);
        } catch (const Error& err) {
          p.fail(where + ": " + err.what());
        }
    }
    s.events.push_back(std::move(ev));
  }
  return s;
}

SessionScript readSessionScript(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open session script '" + path + "'");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (ss.str().size() > (std::size_t{1} << 30)) throw Error(path + ": script is larger than 1 GiB");
  return parseSessionScript(ss.str(), path);
}

std::string formatSessionScript(const SessionScript& s) {
  json doc;
  doc["format"] = "handson-session";
  doc["version"] = kSessionScriptVersion;
  doc["volume"] = s.volumeSource == "file" ? json{{"source", "file"}, {"path", s.volumePath}} : json{{"source", "phantom"}};
  doc["viewport"] = {s.viewport.width, s.viewport.height};
  if (!s.preset.empty()) doc["preset"] = s.preset;
  doc["mode"] = s.mode;
  if (s.camera) {
    const CameraState& c = *s.camera;
    doc["camera"] = {{"target", {c.target.x, c.target.y, c.target.z}}, {"distance", c.distance}, {"azimuth_deg", c.azimuthDeg},
                     {"elevation_deg", c.elevationDeg}, {"roll_deg", c.rollDeg}, {"fov_deg", c.fovDeg}};
  }
  if (s.freeArea) doc["free_area"] = {s.freeArea->x0, s.freeArea->y0, s.freeArea->x1, s.freeArea->y1};
  json events = json::array();
  for (const auto& e : s.events) {
    json j;
    j["t"] = e.t;
    if (e.isTouch) {
      j["touch"] = touchPhaseName(e.touch.phase);
      j["id"] = e.touch.id;
      j["x"] = e.touch.px.x;
      j["y"] = e.touch.px.y;
      if (e.touch.pressure != 1.0) j["pressure"] = e.touch.pressure;
    } else {
      j["ui"] = uiActionName(e.action);
      if (!e.value.empty()) j["value"] = e.value;
    }
    events.push_back(std::move(j));
  }
  doc["events"] = std::move(events);
  // One event per line keeps recorded scripts readable and diffable.
  std::string out = "{\n";
  bool first = true;
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    if (it.key() == "events") continue;
    out += std::string(first ? "" : ",\n") + "  " + json(it.key()).dump() + ": " + it.value().dump();
    first = false;
  }
  out += ",\n  \"events\": [";
  for (std::size_t i = 0; i < doc["events"].size(); ++i) out += std::string(i ? ",\n    " : "\n    ") + doc["events"][i].dump();
  out += "\n  ]\n}\n";
  return out;
}

ScriptEvent uiEvent(double t, UiAction action, std::string value) {
  ScriptEvent e;
  e.t = t;
  e.isTouch = false;
  e.action = action;
  e.value = std::move(value);
  return e;
}

ScriptEvent touchEvent(double t, TouchPhase phase, std::int64_t id, glm::dvec2 px, double pressure) {
  ScriptEvent e;
  e.t = t;
  e.touch.phase = phase;
  e.touch.id = id;
  e.touch.px = px;
  e.touch.pressure = pressure;
  e.touch.time = t;
  return e;
}

void writeSessionScript(const SessionScript& script, const std::string& path) {
  AtomicFile file(path);
  {
    std::ofstream out(file.tempPath(), std::ios::binary | std::ios::trunc);
    out << formatSessionScript(script);
    out.flush();
    if (!out) throw Error("cannot write '" + path + "'");
  }
  file.commit();
}

}  // namespace handson
