#include "session_recovery.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "app/session/session.h"
#include "sim/base/atomic_file.h"
#include "sim/base/error.h"

namespace handson {

using nlohmann::json;

namespace {

constexpr int kHandlesVersion = 1;

void writeText(const std::string& text, const std::string& path) {
  AtomicFile file(path);
  {
    std::ofstream out(file.tempPath(), std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw Error("cannot write '" + path + "'");
  }
  file.commit();
}

}  // namespace

std::string formatHandles(const HandleSet& handles, const std::vector<int>& picked, const Eigen::Vector3i& dims) {
  json list = json::array();
  for (const Handle& h : handles.handles()) {
    json runs = json::array();
    for (std::size_t i = 0; i < h.voxels.size();) {
      std::size_t j = i + 1;
      while (j < h.voxels.size() && h.voxels[j] == h.voxels[j - 1] + 1) ++j;
      runs.push_back({h.voxels[i], j - i});
      i = j;
    }
    json rotation = json::array();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) rotation.push_back(h.pose.R(r, c));
    list.push_back({{"id", h.id},
                    {"status", handleStatusName(h.status)},
                    {"voxels", h.voxels.size()},
                    {"runs", runs},
                    {"rotation", rotation},
                    {"translation", {h.pose.t.x(), h.pose.t.y(), h.pose.t.z()}}});
  }
  json doc = {{"format", "handson-handles"},
              {"version", kHandlesVersion},
              {"dims", {dims.x(), dims.y(), dims.z()}},
              {"picked", picked},
              {"handles", list}};
  return doc.dump(1) + "\n";
}

void writeHandles(const HandleSet& handles, const std::vector<int>& picked, const Eigen::Vector3i& dims, const std::string& path) {
  writeText(formatHandles(handles, picked, dims), path);
}

SavedHandles parseHandles(const std::string& text, const std::string& name) {
  auto fail = [&](const std::string& why) -> Error { return Error(name + ": " + why); };
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::exception& e) {
    throw fail(std::string("not valid JSON (") + e.what() + ")");
  }
  try {
    if (!doc.is_object() || doc.value("format", std::string()) != "handson-handles")
      throw fail("not a handles file (\"format\" is not \"handson-handles\")");
    if (!doc.contains("version") || !doc["version"].is_number_integer() || doc["version"].get<int>() != kHandlesVersion)
      throw fail("unsupported version (this build reads version " + std::to_string(kHandlesVersion) + ")");
    SavedHandles out;
    const json& d = doc.at("dims");
    if (!d.is_array() || d.size() != 3) throw fail("\"dims\" must be three voxel counts");
    for (int i = 0; i < 3; ++i) {
      if (!d[i].is_number_integer() || d[i].get<long long>() < 1 || d[i].get<long long>() > 65535)
        throw fail("\"dims\" must be three voxel counts in 1..65535");
      out.dims[i] = d[i].get<int>();
    }
    const std::uint64_t voxelCount = std::uint64_t(out.dims.x()) * std::uint64_t(out.dims.y()) * std::uint64_t(out.dims.z());
    if (voxelCount > (std::uint64_t{1} << 32)) throw fail("\"dims\" describe more voxels than a handle index can address");
    std::set<int> ids;
    for (const json& jh : doc.at("handles")) {
      Handle h;
      if (!jh.at("id").is_number_integer()) throw fail("a handle id must be an integer");
      const long long id = jh.at("id").get<long long>();
      if (id < 1 || id > HandleSet::kMaxHandles) throw fail("handle id " + std::to_string(id) + " is outside 1..254");
      h.id = int(id);
      if (!ids.insert(h.id).second) throw fail("handle id " + std::to_string(h.id) + " appears twice");
      if (!parseHandleStatus(jh.at("status").get<std::string>(), h.status))
        throw fail("handle " + std::to_string(h.id) + ": unknown status '" + jh.at("status").get<std::string>() + "'");
      std::uint64_t end = 0;
      for (const json& run : jh.at("runs")) {
        if (!run.is_array() || run.size() != 2 || !run[0].is_number_unsigned() || !run[1].is_number_unsigned())
          throw fail("handle " + std::to_string(h.id) + ": a run must be [start, length] with non-negative integers");
        const std::uint64_t start = run[0].get<std::uint64_t>(), length = run[1].get<std::uint64_t>();
        if (length == 0 || start < end || start + length > voxelCount || start + length < start)
          throw fail("handle " + std::to_string(h.id) + ": runs must be non-empty, sorted, apart and inside the grid");
        if (h.voxels.size() + length > voxelCount) throw fail("handle " + std::to_string(h.id) + ": more voxels than the grid has");
        for (std::uint64_t v = start; v < start + length; ++v) h.voxels.push_back(std::uint32_t(v));
        end = start + length;
      }
      if (!jh.at("voxels").is_number_unsigned() || jh.at("voxels").get<std::uint64_t>() != h.voxels.size())
        throw fail("handle " + std::to_string(h.id) + ": \"voxels\" does not match its runs");
      const json& r = jh.at("rotation");
      const json& t = jh.at("translation");
      if (!r.is_array() || r.size() != 9 || !t.is_array() || t.size() != 3)
        throw fail("handle " + std::to_string(h.id) + ": the pose needs 9 rotation and 3 translation numbers");
      for (int k = 0; k < 9; ++k) {
        if (!r[k].is_number()) throw fail("handle " + std::to_string(h.id) + ": the rotation holds a non-number");
        h.pose.R(k / 3, k % 3) = r[k].get<double>();
      }
      for (int k = 0; k < 3; ++k) {
        if (!t[k].is_number()) throw fail("handle " + std::to_string(h.id) + ": the translation holds a non-number");
        h.pose.t[k] = t[k].get<double>();
      }
      // A rotation to within the rounding of 17 significant digits.
      if (!h.pose.R.allFinite() || !h.pose.t.allFinite() ||
          (h.pose.R.transpose() * h.pose.R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-9 ||
          h.pose.R.determinant() < 0.0)
        throw fail("handle " + std::to_string(h.id) + ": the pose is not a finite rigid motion");
      out.handles.push_back(std::move(h));
    }
    // No voxel in two handles.
    std::vector<std::uint32_t> all;
    for (const Handle& h : out.handles) all.insert(all.end(), h.voxels.begin(), h.voxels.end());
    std::sort(all.begin(), all.end());
    if (std::adjacent_find(all.begin(), all.end()) != all.end()) throw fail("a voxel belongs to two handles");
    for (const json& p : doc.at("picked")) {
      if (!p.is_number_integer() || !ids.count(p.get<int>())) throw fail("\"picked\" names a handle that is not in the file");
      out.picked.push_back(p.get<int>());
    }
    return out;
  } catch (const json::exception& e) {
    throw fail(std::string("missing or mistyped field (") + e.what() + ")");
  }
}

SavedHandles readHandles(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open handles file '" + path + "'");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parseHandles(text, path);
}

std::string saveRecovery(const Session& session, const HandleSet& handles, const std::vector<int>& picked,
                         const Eigen::Vector3i& dims, const std::string& dir) {
  try {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (!std::filesystem::is_directory(dir)) return "the session could not be saved: cannot create the directory '" + dir + "'";
    const std::string script = (std::filesystem::path(dir) / "recovery-session.json").string();
    const std::string saved = (std::filesystem::path(dir) / "recovery-handles.json").string();
    writeSessionScript(session.script(), script);
    writeHandles(handles, picked, dims, saved);
    return "the session so far is saved: " + script + " (" + std::to_string(session.script().events.size()) +
           " events; `handson replay` plays it) and " + saved + " (" + std::to_string(handles.handles().size()) +
           (handles.handles().size() == 1 ? " handle)" : " handles)");
  } catch (const std::exception& e) {
    return std::string("the session could not be saved: ") + e.what();
  }
}

}  // namespace handson
