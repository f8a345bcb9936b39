#include "scene_cache.h"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <chrono>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "sim/base/atomic_file.h"
#include "sim/base/binary_io.h"
#include "sim/slide_io.h"
#include "sim/source_hash.h"
#include "sim/base/error.h"
#include "sim/static_solver.h"

namespace handson {

namespace {

constexpr char kMagic[8] = {'H', 'S', 'I', 'M', 'C', 'A', 'C', '1'};
// 3: a coarse element records whether it holds a sliding interface (CoarseModel::Element::slides).
constexpr std::uint32_t kFormat = 3;

// Two FNV-1a 64-bit hashes with different offsets: a 128-bit key.
struct Hasher {
  std::uint64_t a = 0xcbf29ce484222325ull, b = 0x84222325cbf29ce4ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      a = (a ^ c[i]) * 0x100000001b3ull;
      b = (b ^ c[i]) * 0x100000001b3ull;
      b ^= b >> 29;
    }
  }
  template <class T>
  void pod(const T& v) {
    bytes(&v, sizeof v);
  }
  void string(const std::string& s) {
    pod(s.size());
    bytes(s.data(), s.size());
  }
};

void writeGrid(bin::Writer& w, const KuhnGrid& g) {
  w.pod(g.origin());
  w.pod(g.cell());
  w.pod(g.cells());
}
KuhnGrid readGrid(bin::Reader& r) {
  const auto o = r.pod<Eigen::Vector3d>();
  const auto c = r.pod<Eigen::Vector3d>();
  const auto n = r.pod<Eigen::Vector3i>();
  return KuhnGrid(o, c, n);  // validates
}

}  // namespace

std::string simulationCacheKey(const Volume& image, const std::vector<SimHandle>& handles, const SimSettings& s) {
  Hasher h;
  h.pod(kFormat);
  h.string(HANDSON_SIM_SOURCE_HASH);  // the code that builds the scene and the model
  const VolumeGeometry& g = image.geometry();
  h.pod(g.dims);
  h.pod(g.spacing);
  h.pod(g.origin);
  h.pod(g.direction);
  h.pod(image.type());
  h.bytes(image.bytes(), image.byteSize());
  h.pod(handles.size());
  for (const auto& hd : handles) {
    h.pod(hd.voxels.size());
    h.bytes(hd.voxels.data(), hd.voxels.size() * sizeof(std::uint32_t));
    h.pod(hd.reach.size());
    for (const auto& T : hd.reach) {
      h.pod(T.R);
      h.pod(T.t);
    }
  }
  h.pod(s.coarseTets);
  h.pod(s.fineTets);
  h.pod(s.paddingMm);
  h.pod(s.wholeVolume);
  h.pod(s.wholeVolume ? SimSettings::Region::Box : s.region);  // the whole volume has no shape
  h.pod(s.element);
  h.pod(s.fineMesh);
  h.pod(s.adaptContrast);
  h.pod(s.handleNodes);
  h.pod(s.bone);
  h.pod(s.skeletonReachMm);
  h.pod(s.outer);
  h.pod(s.interface);
  h.pod(s.materials.units());
  for (const auto& b : s.materials.bands()) {
    h.string(b.name);
    h.pod(b.lower);
    h.pod(b.upper);
    h.pod(b.youngs);
    h.pod(b.poisson);
    h.pod(b.skeleton);
  }
  char hex[33];
  std::snprintf(hex, sizeof hex, "%016llx%016llx", static_cast<unsigned long long>(h.a), static_cast<unsigned long long>(h.b));
  return hex;
}

void saveSimulation(const std::filesystem::path& file, const SimScene& sc, const CoarseModel& model) {
  std::ostringstream os(std::ios::binary);  // the payload, then its checksum: corruption is detected
  {
    bin::Writer w{os};
    os.write(kMagic, sizeof kMagic);
    w.pod(kFormat);
    w.pod(std::uint32_t(0x01020304));  // byte order
    w.pod(sc.lo);
    w.pod(sc.hi);
    const NestedMeshes& m = sc.meshes;
    writeGrid(w, m.coarseGrid);
    writeGrid(w, m.fineGrid);
    w.pod(std::int32_t(m.refinement));
    w.podVector(m.coarse.nodes);
    w.podVector(m.coarse.tets);
    w.podVector(m.fine.nodes);
    w.podVector(m.fine.tets);
    w.podVector(m.fineParent);
    w.podVector(m.coarseNodeInFine);
    w.pod(std::uint8_t(m.regularFine));
    w.podVector(m.cellTetStart);
    w.podVector(m.cellTets);
    w.podVector(sc.band);
    w.podVector(sc.youngs);
    w.podVector(sc.poisson);
    w.podVector(sc.constraints.handleOf);
    w.podVector(sc.constraints.fixed);
    w.pod(std::int32_t(sc.constraints.handleCount));
    bin::writeSlideNodes(w, sc.constraints.slide);
    w.podVector(sc.handleCentroid);
    w.podVector(sc.handleNodeCount);
    w.podVector(sc.regionCell);
    w.pod(std::uint64_t(sc.adapted.structurePoints));
    w.pod(std::uint64_t(sc.adapted.fallbackCells));
    w.string(sc.adapted.firstFailure);
    model.save(os);
    os.write(kMagic, sizeof kMagic);  // end marker
  }
  const std::string payload = std::move(os).str();
  Hasher h;
  h.bytes(payload.data(), payload.size());
  AtomicFile out(file.string(), "the simulation cache");
  out.write(payload.data(), payload.size());
  out.write(&h.a, sizeof h.a);
  out.write(&h.b, sizeof h.b);
  out.commit();
}

std::unique_ptr<CoarseModel> loadSimulation(const std::filesystem::path& file, SimScene& sc) {
  std::error_code ec;
  const auto fileSize = std::filesystem::file_size(file, ec);
  if (ec) throw Error("no simulation cache '" + file.string() + "'");
  if (fileSize < 16 + 2 * sizeof kMagic) throw Error("simulation cache truncated");
  std::string payload(fileSize - 16, '\0');
  std::uint64_t sum[2] = {0, 0};
  {
    std::ifstream in(file, std::ios::binary);
    if (!in || !in.read(payload.data(), std::streamsize(payload.size())) || !in.read(reinterpret_cast<char*>(sum), sizeof sum))
      throw Error("cannot read the simulation cache '" + file.string() + "'");
  }
  Hasher h;
  h.bytes(payload.data(), payload.size());
  if (h.a != sum[0] || h.b != sum[1]) throw Error("simulation cache corrupt (checksum)");
  std::istringstream is(std::move(payload), std::ios::binary);
  bin::Reader r{is, fileSize - 16};
  char magic[8];
  r.need(sizeof magic);
  if (!is.read(magic, sizeof magic) || std::memcmp(magic, kMagic, sizeof magic) != 0) throw Error("not a simulation cache file");
  if (r.pod<std::uint32_t>() != kFormat || r.pod<std::uint32_t>() != 0x01020304u) throw Error("simulation cache of another format version");
  sc = SimScene{};
  sc.lo = r.pod<Eigen::Vector3d>();
  sc.hi = r.pod<Eigen::Vector3d>();
  NestedMeshes& m = sc.meshes;
  m.coarseGrid = readGrid(r);
  m.fineGrid = readGrid(r);
  m.refinement = r.pod<std::int32_t>();
  m.coarse.nodes = r.podVector<Eigen::Vector3d>();
  m.coarse.tets = r.podVector<std::array<int, 4>>();
  m.fine.nodes = r.podVector<Eigen::Vector3d>();
  m.fine.tets = r.podVector<std::array<int, 4>>();
  m.fineParent = r.podVector<int>();
  m.coarseNodeInFine = r.podVector<int>();
  m.regularFine = r.pod<std::uint8_t>() != 0;
  m.cellTetStart = r.podVector<int>();
  m.cellTets = r.podVector<int>();
  sc.band = r.podVector<int>();
  sc.youngs = r.podVector<double>();
  sc.poisson = r.podVector<double>();
  sc.constraints.handleOf = r.podVector<int>();
  sc.constraints.fixed = r.podVector<char>();
  sc.constraints.handleCount = r.pod<std::int32_t>();
  sc.constraints.slide = bin::readSlideNodes(r, sc.constraints.handleOf, sc.constraints.fixed, sc.constraints.handleCount);
  sc.handleCentroid = r.podVector<Eigen::Vector3d>();
  sc.handleNodeCount = r.podVector<std::size_t>();
  sc.regionCell = r.podVector<char>();
  sc.adapted.structurePoints = r.pod<std::uint64_t>();
  sc.adapted.fallbackCells = r.pod<std::uint64_t>();
  sc.adapted.firstFailure = r.string();
  // Consistency: every index in range, every per-item array the right length.
  const std::size_t nf = m.fine.nodes.size(), nt = m.fine.tets.size(), nc = m.coarse.nodes.size();
  auto bad = [] { throw Error("simulation cache corrupt (inconsistent mesh)"); };
  if (nt == 0 || nc == 0 || m.fineParent.size() != nt || m.coarseNodeInFine.size() != nc || sc.band.size() != nt || sc.youngs.size() != nt ||
      sc.poisson.size() != nt || sc.constraints.handleOf.size() != nf || sc.constraints.fixed.size() != nf || m.coarse.tets.size() != m.coarseGrid.tetCount() ||
      (!sc.regionCell.empty() && sc.regionCell.size() != m.coarseGrid.cellCount()))
    bad();
  for (const auto& t : m.fine.tets)
    for (int v : t)
      if (v < 0 || std::size_t(v) >= nf) bad();
  for (const auto& t : m.coarse.tets)
    for (int v : t)
      if (v < 0 || std::size_t(v) >= nc) bad();
  for (int p : m.fineParent)
    if (p < 0 || std::size_t(p) >= m.coarse.tets.size()) bad();
  for (int v : m.coarseNodeInFine)
    if (v < 0 || std::size_t(v) >= nf) bad();
  if (!m.regularFine) {
    if (m.cellTetStart.size() != m.coarseGrid.cellCount() + 1 || m.cellTets.size() != nt) bad();
    for (int v : m.cellTets)
      if (v < 0 || std::size_t(v) >= nt) bad();
    for (std::size_t i = 0; i + 1 < m.cellTetStart.size(); ++i)
      if (m.cellTetStart[i] < 0 || m.cellTetStart[i] > m.cellTetStart[i + 1] || std::size_t(m.cellTetStart[i + 1]) > nt) bad();
  }
  const int hc = sc.constraints.handleCount;
  if (hc < 0 || sc.handleCentroid.size() != std::size_t(hc) || sc.handleNodeCount.size() != std::size_t(hc)) bad();
  for (int role : sc.constraints.handleOf)
    if (role < -1 || role >= hc) bad();
  for (std::size_t t = 0; t < nt; ++t)  // a sliding handle's own tets carry no stiffness
    if (!(sc.youngs[t] > 0 || (sc.youngs[t] == 0 && sc.band[t] == kRigidBand)) || !std::isfinite(sc.youngs[t])) bad();
  for (double v : sc.poisson)
    if (!(v > -1 && v < 0.5)) bad();
  auto model = CoarseModel::load(is, r.remaining, m);
  if (model->constraints().handleCount != hc || model->constraints().slide.size() != sc.constraints.slide.size()) bad();
  for (std::size_t i = 0; i < sc.constraints.slide.size(); ++i)
    if (model->constraints().slide[i].node != sc.constraints.slide[i].node || model->constraints().slide[i].handle != sc.constraints.slide[i].handle) bad();
  if (model->elementKind() == CoarseElement::Tet && !m.regularFine) bad();
  char end[8];
  if (!is.read(end, sizeof end) || std::memcmp(end, kMagic, sizeof end) != 0) throw Error("simulation cache truncated (no end marker)");
  sc.fineK = tetStiffnesses(m.fine, sc.youngs, sc.poisson);
  return model;
}

std::unique_ptr<CoarseModel> buildOrLoadSimulation(const Volume& image, const std::vector<SimHandle>& handles, const SimSettings& settings,
                                                   SimScene& scene, const CacheUse& cache, const ProgressFn& progress) {
  const std::filesystem::path& cacheDir = cache.dir;
  CacheOutcome* outcome = cache.outcome;
  const std::uint64_t maxCacheBytes = cache.maxBytes;
  CacheOutcome local;
  CacheOutcome& o = outcome ? *outcome : local;
  o = CacheOutcome{};
  auto build = [&] {
    scene = buildSimScene(image, handles, settings, progress);
    auto m = std::make_unique<CoarseModel>(scene.meshes, scene.fineK, scene.constraints, progress, settings.element, settings.grading);
    m->setSolver(settings.coarseSolver);  // how it iterates: not part of the cached data
    return m;
  };
  if (cacheDir.empty()) return build();
  if (settings.grading.graded()) {
    o.note = "graded cells are not cached: built afresh";
    return build();
  }
  const std::filesystem::path file = cacheDir / (simulationCacheKey(image, handles, settings) + ".hsim");
  std::error_code ec;
  if (std::filesystem::exists(file, ec)) {
    try {
      reportProgress(progress, 0.0, "loading cached simulation");
      auto model = loadSimulation(file, scene);
      if (model->elementKind() != settings.element) throw Error("the cached model has other elements");
      reportProgress(progress, 1.0, "loading cached simulation");
      o.hit = true;
      std::filesystem::last_write_time(file, std::filesystem::file_time_type::clock::now(), ec);  // recently used
      model->setSolver(settings.coarseSolver);
      return model;
    } catch (const std::exception& e) {  // corrupt data, or a garbage file too large to read
      o.note = std::string("the cached simulation was unreadable (") + e.what() + "): rebuilt";
      std::filesystem::remove(file, ec);
    }
  }
  auto model = build();
  try {
    std::filesystem::create_directories(cacheDir, ec);
    saveSimulation(file, scene, *model);
    // Evict the least recently used entries beyond the cap.
    std::vector<std::pair<std::filesystem::file_time_type, std::filesystem::path>> entries;
    std::uint64_t total = 0;
    const auto now = std::filesystem::file_time_type::clock::now();
    for (const auto& e : std::filesystem::directory_iterator(cacheDir, ec)) {
      // Temporary files a killed writer left behind (an hour old) go too.
      if (e.path().string().find(".hsim.tmp") != std::string::npos && now - e.last_write_time(ec) > std::chrono::hours(1)) {
        std::filesystem::remove(e.path(), ec);
        continue;
      }
      if (e.path().extension() != ".hsim") continue;
      total += e.file_size(ec);
      entries.emplace_back(e.last_write_time(ec), e.path());
    }
    std::sort(entries.begin(), entries.end());
    for (const auto& [t, p] : entries) {
      if (total <= maxCacheBytes || p == file) continue;
      const auto sz = std::filesystem::file_size(p, ec);
      if (std::filesystem::remove(p, ec)) total -= std::min<std::uint64_t>(total, sz);
    }
  } catch (const std::exception& e) {
    if (o.note.empty()) o.note = std::string("the simulation was not cached: ") + e.what();
  }
  return model;
}

std::filesystem::path defaultSimulationCacheDir() {
  if (const char* d = std::getenv("HANDSON_CACHE_DIR"); d && *d) return d;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::filesystem::path(x) / "handson";
  if (const char* h = std::getenv("HOME"); h && *h) return std::filesystem::path(h) / ".cache" / "handson";
  return {};
}

}  // namespace handson
