#pragma once
// The deformation's strain passes (docs/gpu-deformation.md): per fine tet, the largest principal
// stretch - 1 of its deformation gradient at the frame's fine positions (deform_strain.comp), and
// the strain volume on the deformed volume's grid, redone over the frame's box or dirty bricks:
// each voxel the strain of the tet it was sampled through, 0 where none (deform_strain_raster.comp).
// With strain limits the raster also writes each voxel's strain over its tet's limit (0 where the
// tissue has none). CPU references: tetStrain and strainVolume (sim/strain.h),
// strainOverLimitVolume (sim/tissue_limits.h). GpuDeformer runs it after its resampling.
#include <cstddef>
#include <memory>
#include <vector>

#include "frame_graph.h"
#include "vk_resources.h"

namespace handson::vk {

class Context;
class GraphExecutor;

class DeformStrainPass {
 public:
  /// `tets`: fine tets; `grid`: the deformed volume's; `limits`: per fine tet its tissue's strain
  /// limit (inf: none; checked by the deformer's setup), null: no limits.
  DeformStrainPass(const Context& ctx, std::size_t tets, const fg::ImageDesc& grid, const std::vector<float>* limits);

  /// What the passes read of the deformation's frame: its handles in this graph.
  struct Inputs {
    fg::ResourceHandle params;     ///< gpu::DeformParams
    fg::ResourceHandle tets, rest; ///< fine tets, fine rest positions
    fg::ResourceHandle positions;  ///< this frame's fine positions (voxel index space)
    fg::ResourceHandle args, box, owner, brickList;  ///< the resampling's dispatch, box, owners and dirty bricks
  };
  struct Outputs {
    fg::ResourceHandle perTet;     ///< float per fine tet (NaN for a degenerate one)
    fg::ResourceHandle volume;     ///< R32 float, the volume's grid, left in Access::Sampled
    fg::ResourceHandle overLimit;  ///< R32 float strain over limit, likewise (invalid without limits)
  };
  /// Forgets the last frame's handles (a new graph).
  void beginFrame() { h_ = {}; }
  /// Adds both passes (after the resampling's resolve pass, in the same graph).
  Outputs add(fg::FrameGraph& g, const Inputs& in);
  /// Imports the volumes as the last passes left them (a frame without new positions); invalid
  /// handles before the first add (perTet is never imported).
  Outputs importVolumes(fg::FrameGraph& g);

  bool hasLimits() const { return hasLimits_; }
  /// Read back after a frame with the passes (x fastest for the volumes).
  std::vector<float> readPerTet() const;
  std::vector<float> readVolume() const;
  std::vector<float> readOverLimitVolume() const;

 private:
  void allocate();  // the per-tet buffer and the volumes, at the first add
  const Context& ctx_;
  std::size_t tets_;
  fg::ImageDesc grid_;
  bool hasLimits_;
  ComputePipeline strain_, raster_;
  Buffer limits_;                    ///< float per fine tet (1 float, unused, without limits)
  std::unique_ptr<Buffer> perTet_;   ///< float per fine tet, made by the first add
  Image volume_;                     ///< R32 float, made (zero) by the first add
  Image overLimit_;                  ///< R32 float, made (zero) by the first add (1 voxel without limits)
  struct Handles {
    fg::ResourceHandle perTet, volume, limits, overLimit;
  } h_;
};

}  // namespace handson::vk
