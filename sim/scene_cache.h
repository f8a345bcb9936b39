#pragma once
// The simulation's preprocessing cached on disk (issue: a second open of the same volume skips it):
// the scene (region, nested meshes, materials, Dirichlet roles) and the coarse model (condensed
// elements, the fine reconstruction), keyed by a 128-bit hash of everything they depend on: the
// image's grid, type and values, the handles' voxels and reach, and the settings (resolutions,
// padding, element kind, fine mesh kind, material table). One file per key, written atomically;
// a missing, truncated or corrupt file is rebuilt (and replaced), never trusted. Per-tet stiffness
// is recomputed on load (it would be most of the file). Old entries beyond a size cap are evicted,
// oldest first.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/coarsening.h"
#include "sim/base/progress.h"
#include "sim/sim_scene.h"
#include "sim/volume.h"

namespace handson {

/// The key (32 hex digits) of a scene and its coarse model.
std::string simulationCacheKey(const Volume& image, const std::vector<SimHandle>& handles, const SimSettings& settings);

/// Writes scene + model to `file` (atomically). Throws handson::Error on I/O failure.
void saveSimulation(const std::filesystem::path& file, const SimScene& scene, const CoarseModel& model);
/// Reads them back into `scene`; the model refers to scene.meshes. Throws handson::Error when the
/// file is missing, truncated, corrupt or of another format version.
std::unique_ptr<CoarseModel> loadSimulation(const std::filesystem::path& file, SimScene& scene);

struct CacheOutcome {
  bool hit = false;
  std::string note;  ///< a rebuilt corrupt entry, a failed save: said, never fatal
};

/// Where the preprocessing is cached, and what happened there.
struct CacheUse {
  std::filesystem::path dir;            ///< empty: no cache
  CacheOutcome* outcome = nullptr;      ///< a hit, a note (none: not reported)
  std::uint64_t maxBytes = 4ull << 30;  ///< eviction cap
};

/// The scene and coarse model from the cache when there (progress "loading cached simulation"),
/// else built (and saved there).
std::unique_ptr<CoarseModel> buildOrLoadSimulation(const Volume& image, const std::vector<SimHandle>& handles, const SimSettings& settings,
                                                   SimScene& scene, const CacheUse& cache, const ProgressFn& progress = {});

/// $HANDSON_CACHE_DIR, else $XDG_CACHE_HOME/handson, else $HOME/.cache/handson ("" if none is set).
std::filesystem::path defaultSimulationCacheDir();

}  // namespace handson
