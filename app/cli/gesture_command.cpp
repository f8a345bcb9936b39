// `handson gesture-solve`: one gesture-solve case in JSON, the rigid increment out (a developer and
// research tool for the solver in interaction/gesture_solve.h).
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/cli/args.h"
#include "app/cli/commands.h"
#include "interaction/gesture_solve.h"
#include "sim/base/error.h"

namespace handson::cli {

namespace {

const char* const kHelp =
    "usage: handson gesture-solve --input FILE|-\n"
    "  Reads one case as JSON and prints the rigid increment as JSON:\n"
    "  in:  {\"projection\": [[a,b,c],[d,e,f]], \"points\": [[x,y,z],...], \"targets\": [[u,v],...],\n"
    "        \"solver\": \"linearized\"|\"lm\"|\"substeps\", \"locks\": [\"z-translation\"|\"z-rotation\"|\"xy-translation\",...]}\n"
    "       points in view space (camera at the origin looking along +z, depth z > 0); a point v\n"
    "       projects to NDC as P v / v_z with P the 2x3 projection. 1 point: screen-plane translation;\n"
    "       2: xyz translation + rotation about the view axis; 3+: full 6 DoF. \"substeps\": the\n"
    "       linearized solve in 0.004-NDC sub-steps (as the app does).\n"
    "  out: {\"rotation\": [[...],[...],[...]], \"translation\": [x,y,z], \"ok\": bool, \"clamped\": bool,\n"
    "        \"reason\": \"...\", \"rms_before\": e, \"rms_after\": e, \"iterations\": n} with new points R q + t.\n";

using nlohmann::json;

double num(const json& v, const std::string& what) {
  if (!v.is_number()) throw Error(what + " must be a number");
  return v.get<double>();
}

}  // namespace

int cmdGestureSolve(const Words& words) {
  Args args(words, {"--input"}, {});
  if (args.help() || !args.value("--input") || !args.positional().empty()) {
    usageStream(args) << kHelp;
    return args.help() ? 0 : 2;
  }
  std::string text;
  const std::string in = *args.value("--input");
  if (in == "-") {
    text.assign(std::istreambuf_iterator<char>(std::cin), {});
  } else {
    std::ifstream f(in, std::ios::binary);
    if (!f) throw Error("cannot open '" + in + "'");
    text.assign(std::istreambuf_iterator<char>(f), {});
  }
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    throw Error(std::string("gesture-solve: not valid JSON (") + e.what() + ")");
  }
  if (!doc.is_object()) throw Error("gesture-solve: the input must be a JSON object");
  GestureProblem p;
  const auto& P = doc.value("projection", json());
  if (!P.is_array() || P.size() != 2 || !P[0].is_array() || !P[1].is_array() || P[0].size() != 3 || P[1].size() != 3)
    throw Error("gesture-solve: \"projection\" must be a 2x3 array of numbers");
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) p.projection(r, c) = num(P[r][c], "projection entries");
  const auto& pts = doc.value("points", json());
  const auto& tgs = doc.value("targets", json());
  if (!pts.is_array() || !tgs.is_array()) throw Error("gesture-solve: \"points\" and \"targets\" must be arrays");
  if (pts.size() != tgs.size()) throw Error("gesture-solve: \"points\" and \"targets\" must have the same length");
  if (pts.empty() || pts.size() > 100000) throw Error("gesture-solve: between 1 and 100000 points");
  for (const auto& q : pts) {
    if (!q.is_array() || q.size() != 3) throw Error("gesture-solve: each point must be [x, y, z]");
    p.points.emplace_back(num(q[0], "point"), num(q[1], "point"), num(q[2], "point"));
  }
  for (const auto& t : tgs) {
    if (!t.is_array() || t.size() != 2) throw Error("gesture-solve: each target must be [u, v]");
    p.targets.emplace_back(num(t[0], "target"), num(t[1], "target"));
  }
  if (auto it = doc.find("locks"); it != doc.end()) {
    if (!it->is_array()) throw Error("gesture-solve: \"locks\" must be an array");
    for (const auto& l : *it) {
      unsigned lock = 0;
      if (!l.is_string() || !parseGestureLock(l.get<std::string>(), lock))
        throw Error("gesture-solve: unknown lock (z-translation, z-rotation, xy-translation)");
      p.locks |= lock;
    }
  }
  const std::string solver = doc.value("solver", std::string("linearized"));
  RigidIncrement r;
  if (solver == "linearized") r = solveLinearized(p);
  else if (solver == "lm") r = solveLevenbergMarquardt(p);
  else if (solver == "substeps") r = solveLinearizedSubsteps(p);
  else throw Error("gesture-solve: \"solver\" must be \"linearized\", \"lm\" or \"substeps\"");
  json out;
  out["rotation"] = json::array();
  for (int i = 0; i < 3; ++i) out["rotation"].push_back({r.motion.R(i, 0), r.motion.R(i, 1), r.motion.R(i, 2)});
  out["translation"] = {r.motion.t.x(), r.motion.t.y(), r.motion.t.z()};
  out["ok"] = r.ok;
  out["clamped"] = r.clamped;
  out["reason"] = r.reason;
  out["rms_before"] = r.rmsBefore;
  out["rms_after"] = std::isfinite(r.rmsAfter) ? json(r.rmsAfter) : json(nullptr);
  out["iterations"] = r.iterations;
  std::cout << out.dump() << "\n";
  return r.ok ? 0 : 1;
}

}  // namespace handson::cli
