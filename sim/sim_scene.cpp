#include "sim_scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "sim/adapted_mesh.h"
#include "sim/base/error.h"
#include "sim/neo_hookean.h"
#include "sim/region_shape.h"
#include "sim/skeleton.h"
#include "sim/sliding_interface.h"

namespace handson {

namespace {
// Region::Handles: the cells within `padding` of the handles' points, and every cell holding a
// handle voxel with its 26 neighbours (the thinned points stand for their buckets; a handle node on
// a held cell's face would be held at rest, whatever the padding), are simulated; every fine node of
// another cell is held, so the region's boundary is fixed too.
void holdCellsAwayFromHandles(SimScene& sc, const HandlePoints& shape, const std::vector<char>& holdsHandle, double padding) {
  sc.regionCell = cellsNearPoints(sc.meshes.coarseGrid, shape, padding);
  markCellNeighbours(sc.meshes.coarseGrid, holdsHandle, sc.regionCell);
  const TetMesh& F = sc.meshes.fine;
  for (std::size_t t = 0; t < F.tets.size(); ++t)
    if (!sc.regionCell[std::size_t(sc.meshes.fineParent[t] / 6)])
      for (int n : F.tets[t]) sc.constraints.fixed[std::size_t(n)] = 1;
}

// Materials: the tissue at five points of each fine tet (centroid and midway to each corner),
// classified and averaged: Young's modulus harmonically (the Reuss bound, tissues in series), the
// Poisson ratio arithmetically. The tet's band (its strain limit) is its softest sample's, where a
// series composite's strain goes (the centroid's, first, among equally soft). A tet straddling bone and soft
// tissue is then about as soft as its soft part: with the arithmetic mean (the Voigt bound) one bone
// sample in five made it ~1/5 of bone's stiffness, so a handle one tet from the skeleton was held to
// it by gigapascals and its force grew by 100-1000x as the fine mesh was coarsened.
void assignMaterials(SimScene& sc, const TissueMap& tissue) {
  const TetMesh& F = sc.meshes.fine;
  sc.band.resize(F.tets.size());
  sc.youngs.resize(F.tets.size());
  sc.poisson.resize(F.tets.size());
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int v : F.tets[t]) c += F.nodes[std::size_t(v)];
    c /= 4.0;
    double compliance = 0, nu = 0;
    for (int k = 0; k < 5; ++k) {
      const Eigen::Vector3d p = k == 0 ? c : Eigen::Vector3d(0.5 * (c + F.nodes[std::size_t(F.tets[t][std::size_t(k - 1)])]));
      const int b = tissue.bandAt(p);
      if (k == 0 || tissue.table().band(b).youngs < tissue.table().band(sc.band[t]).youngs) sc.band[t] = b;
      compliance += 1.0 / tissue.table().band(b).youngs;  // > 0: the table refuses moduli <= 0
      nu += tissue.table().band(b).poisson;
    }
    sc.youngs[t] = 5.0 / compliance;
    sc.poisson[t] = nu / 5.0;
  }
}

// The exterior layer: the fine tets of the region's outermost coarse cells (along any axis) stand for
// the unbounded tissue beyond the region. Seen from a handle at distance R, that tissue resists a
// displacement u of the region's boundary with a traction k u, k = 6 G (1 - nu) / ((5 - 6 nu) R):
// the average traction on a sphere of radius R translated in an unbounded medium of shear modulus G
// (F = 24 pi G R U (1 - nu) / (5 - 6 nu), 6 pi G R U incompressible). A layer of thickness t whose
// outer face is held has shear stiffness G_L / t per area, so the layer takes G_L = k t with
// Poisson's ratio 0 (E_L = 2 k t; its normal stiffness is then 2k). G and nu are the tet's own
// tissue's; R its distance to the nearest handle centroid (at least t).
void applyExteriorLayer(SimScene& sc) {
  const TetMesh& F = sc.meshes.fine;
  const Eigen::Vector3d cell = sc.meshes.coarseGrid.cell();
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int v : F.tets[t]) c += F.nodes[std::size_t(v)] / 4.0;
    double thickness = 0.0;
    for (int a = 0; a < 3; ++a)
      if (std::min(c[a] - sc.lo[a], sc.hi[a] - c[a]) < cell[a]) thickness = thickness > 0 ? std::min(thickness, cell[a]) : cell[a];
    if (thickness <= 0.0) continue;
    double R = 1e300;
    for (const Eigen::Vector3d& h : sc.handleCentroid) R = std::min(R, (c - h).norm());
    R = std::max(R, thickness);
    const double nu = sc.poisson[t], G = sc.youngs[t] / (2.0 * (1.0 + nu));
    const double k = 6.0 * G * (1.0 - nu) / ((5.0 - 6.0 * nu) * R);
    sc.youngs[t] = 2.0 * k * thickness;
    sc.poisson[t] = 0.0;
    sc.band[t] = kExteriorBand;
  }
}

// Handle nodes under the Tets rule: every node of the fine tets holding handle h's voxel centres.
void claimNodesOfTets(SimScene& sc, const VolumeGeometry& g, const SimHandle& handle, int h) {
  for (std::uint32_t v : handle.voxels) {
    const int t = sc.meshes.locateFine(g.toWorld(g.voxelOf(v).cast<double>()));
    if (t >= 0)  // outside the region otherwise (whole-volume runs include every voxel centre)
      for (int n : sc.meshes.fine.tets[std::size_t(t)]) sc.constraints.handleOf[std::size_t(n)] = h;
  }
}

// Handle nodes under the Inside rule: the nodes whose nearest voxel is one of the handle's (its
// voxels sorted, binary search). Returns how many it claimed.
std::size_t claimNodesInside(SimScene& sc, const VolumeGeometry& g, const SimHandle& handle, int h) {
  std::vector<std::uint32_t> sorted = handle.voxels;
  std::sort(sorted.begin(), sorted.end());
  const TetMesh& F = sc.meshes.fine;
  std::size_t claimed = 0;
  for (std::size_t n = 0; n < F.nodes.size(); ++n) {
    const std::optional<Eigen::Vector3i> v = nearestVoxel(g, F.nodes[n]);
    if (v && std::binary_search(sorted.begin(), sorted.end(), std::uint32_t(linearIndex(g, *v)))) {
      sc.constraints.handleOf[n] = h;
      ++claimed;
    }
  }
  return claimed;
}

// The skeleton is anchored: a node whose nearest voxel is skeleton, and every node of a tet that is
// bone throughout (its softest sample's band is a skeleton band, so all five samples lie on the
// skeleton), unless a handle holds it. The second rule catches the nodes on bone's surface whose
// nearest voxel is soft: left free, such a node is held only through its bone tets (300 MPa and up),
// which the fine model leaves nearly at rest but a coarse cell, whose fine nodes follow its corners,
// stretches with everything else in the cell. ircadb1.1's right kidney moved 6 mm, glued: the coarse
// force 35.8 / 406 / 64.7 N at 1,600 / 3,000 / 6,000 coarse tets against the fine 14.6 / 14.5 /
// 14.4 N; with the rule 21.0 / 19.9 / 19.5 N (results.md, 2026-12-07, seventh entry).
// `boneTet`: per fine tet, bone throughout (boneTets(), taken before the exterior layer renames
// the outer cells' bands).
void anchorSkeleton(SimScene& sc, const TissueMap& tissue, const std::vector<char>& boneTet) {
  const TetMesh& F = sc.meshes.fine;
  for (std::size_t n = 0; n < F.nodes.size(); ++n)
    if (sc.constraints.handleOf[n] < 0 && tissue.skeletonAt(F.nodes[n])) sc.constraints.fixed[n] = 1;
  for (std::size_t t = 0; t < F.tets.size(); ++t)
    if (boneTet[t])
      for (const int n : F.tets[t])
        if (sc.constraints.handleOf[std::size_t(n)] < 0) sc.constraints.fixed[std::size_t(n)] = 1;
}

// Per fine tet: its softest sample's band is a skeleton band, so all five of its samples lie on the
// skeleton (assignMaterials; a "joined" band off the skeleton is the band below).
std::vector<char> boneTets(const SimScene& sc, const TissueMap& tissue) {
  std::vector<char> bone(sc.band.size(), 0);
  if (tissue.skeletonVoxelCount() == 0) return bone;
  for (std::size_t t = 0; t < sc.band.size(); ++t)
    bone[t] = sc.band[t] >= 0 && tissue.table().band(sc.band[t]).skeleton != SkeletonRole::No;
  return bone;
}

// Dirichlet roles: the region's outer faces are fixed; handle nodes by the settings' rule, later
// handles winning (anchorSkeleton, after it, anchors the skeleton's nodes no handle holds).
// `holdsHandle` (shaped regions): the coarse cells holding a handle voxel.
void assignConstraints(SimScene& sc, const Volume& image, const std::vector<SimHandle>& handles, const SimSettings& s,
                       std::vector<char>* holdsHandle) {
  const TetMesh& F = sc.meshes.fine;
  const VolumeGeometry& g = image.geometry();
  sc.constraints.handleCount = int(handles.size());
  sc.constraints.handleOf.assign(F.nodes.size(), -1);
  sc.constraints.fixed.assign(F.nodes.size(), 0);
  const double onFace = 1e-9 * sc.meshes.coarseGrid.cell().maxCoeff();
  for (std::size_t n = 0; n < F.nodes.size(); ++n)
    for (int a = 0; a < 3; ++a)
      if (F.nodes[n][a] <= sc.lo[a] + onFace || F.nodes[n][a] >= sc.hi[a] - onFace) sc.constraints.fixed[n] = 1;
  for (std::size_t h = 0; h < handles.size(); ++h) {
    if (s.handleNodes == SimSettings::HandleNodes::Tets || claimNodesInside(sc, g, handles[h], int(h)) == 0) claimNodesOfTets(sc, g, handles[h], int(h));
    if (holdsHandle)
      for (std::uint32_t v : handles[h].voxels)
        if (const int t = sc.meshes.locateFine(g.toWorld(g.voxelOf(v).cast<double>())); t >= 0) (*holdsHandle)[std::size_t(sc.meshes.fineParent[std::size_t(t)] / 6)] = 1;
  }
}
// Sliding interfaces (sim/sliding_interface.h): each handle's own tets (all four nodes selected by
// it) lose their stiffness and strain limit, and its surface nodes become free nodes held to its
// surface by normal springs. The normals come from the handle's voxels within three of the image's
// largest spacings (a neighbourhood wide enough to smooth the voxels' staircase, fixed with the
// image, not with the mesh); the springs' stiffness from each node's remaining tissue stiffness.
void makeInterfacesSliding(SimScene& sc, const VolumeGeometry& g, const std::vector<SimHandle>& handles) {
  const TetMesh& F = sc.meshes.fine;
  claimEnclosedTissue(F, sc.constraints.handleOf, sc.constraints.fixed);
  const InterfaceNodes in = findInterfaceNodes(F, sc.constraints.handleOf, sc.constraints.fixed);
  for (std::size_t t = 0; t < F.tets.size(); ++t)
    if (in.handleTet[t]) {
      sc.youngs[t] = 0.0;
      sc.band[t] = kRigidBand;
      sc.fineK[t].setZero();
    }
  std::vector<double> diag(F.nodes.size(), 0.0);
  for (std::size_t t = 0; t < F.tets.size(); ++t)
    for (int a = 0; a < 4; ++a) diag[std::size_t(F.tets[t][std::size_t(a)])] += sc.fineK[t].block<3, 3>(3 * a, 3 * a).trace() / 3.0;
  std::vector<HandleMask> masks;
  for (const SimHandle& h : handles) masks.push_back(handleMask(g, h.voxels));
  const double radius = 3.0 * g.spacing.maxCoeff();
  for (std::size_t i = 0; i < in.slideNodes.size(); ++i) {
    const int node = in.slideNodes[i], h = in.slideHandle[i];
    const Eigen::Vector3d n = maskNormal(g, masks[std::size_t(h)], F.nodes[std::size_t(node)], radius);
    sc.constraints.slide.push_back({node, h, n, kSlidePenalty * diag[std::size_t(node)]});
    sc.constraints.handleOf[std::size_t(node)] = -1;
  }
}
}  // namespace

const char* interfaceName(SimSettings::Interface i) { return i == SimSettings::Interface::Sliding ? "sliding" : "glued"; }

std::optional<SimSettings::Interface> parseInterface(const std::string& name) {
  if (name == "glued") return SimSettings::Interface::Glued;
  if (name == "sliding") return SimSettings::Interface::Sliding;
  return std::nullopt;
}

namespace {

// The image's world box (voxel centres), axis-aligned.
std::pair<Eigen::Vector3d, Eigen::Vector3d> imageWorldBox(const VolumeGeometry& g) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d idx((c & 1) ? g.dims.x() - 1 : 0, (c & 2) ? g.dims.y() - 1 : 0, (c & 4) ? g.dims.z() - 1 : 0);
    const Eigen::Vector3d w = g.toWorld(idx);
    lo = lo.cwiseMin(w);
    hi = hi.cwiseMax(w);
  }
  return {lo, hi};
}

// The handles' world box at rest and at every pose they will reach, each handle's centroid (into
// sc), and with `shape` (Region::Handles) the handles as thinned points at rest and at those poses.
std::pair<Eigen::Vector3d, Eigen::Vector3d> handlesBox(const Volume& image, const std::vector<SimHandle>& handles, SimScene& sc, HandlePoints* shape) {
  const VolumeGeometry& g = image.geometry();
  const std::size_t nvox = image.voxelCount();
  std::vector<Eigen::Vector3d> handleWorld;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t h = 0; h < handles.size(); ++h) {
    if (handles[h].voxels.empty()) throw Error("simulation: handle " + std::to_string(h + 1) + " has no voxels");
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Vector3d hlo = Eigen::Vector3d::Constant(1e300), hhi = -hlo;
    handleWorld.clear();
    for (std::uint32_t v : handles[h].voxels) {
      if (v >= nvox) throw Error("simulation: handle " + std::to_string(h + 1) + " has a voxel outside the image");
      const Eigen::Vector3d w = g.toWorld(g.voxelOf(v).cast<double>());
      hlo = hlo.cwiseMin(w);
      hhi = hhi.cwiseMax(w);
      sum += w;
      if (shape) handleWorld.push_back(w);
    }
    lo = lo.cwiseMin(hlo);
    hi = hi.cwiseMax(hhi);
    if (shape) {
      HandlePoints hp = thinHandlePoints(handleWorld, shape->bucketMm);
      const std::size_t n = hp.point.size();
      for (const RigidTransform& T : handles[h].reach)
        for (std::size_t i = 0; i < n; ++i) {
          hp.point.push_back(T.apply(hp.point[i]));
          hp.surface.push_back(hp.surface[i]);
        }
      shape->point.insert(shape->point.end(), hp.point.begin(), hp.point.end());
      shape->surface.insert(shape->surface.end(), hp.surface.begin(), hp.surface.end());
    }
    for (const RigidTransform& T : handles[h].reach) {
      if (!T.R.allFinite() || !T.t.allFinite()) throw Error("simulation: a handle pose is not finite");
      for (int c = 0; c < 8; ++c) {
        const Eigen::Vector3d w = T.apply(Eigen::Vector3d((c & 1) ? hhi.x() : hlo.x(), (c & 2) ? hhi.y() : hlo.y(), (c & 4) ? hhi.z() : hlo.z()));
        lo = lo.cwiseMin(w);
        hi = hi.cwiseMax(w);
      }
    }
    sc.handleCentroid.push_back(sum / double(handles[h].voxels.size()));
  }
  return {lo, hi};
}

// A shaped region spends the element budget on its own cells: the box's grid is made finer until
// about coarseTets of its tets lie in cells near the handles (at most 8x the box's count).
int shapedCoarseTets(const SimScene& sc, const SimSettings& s, const HandlePoints& shape) {
  int coarseTets = s.coarseTets;
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<char> in = cellsNearPoints(coarseGridFor(sc.lo, sc.hi, coarseTets), shape, s.paddingMm);
    const double share = std::max(0.125, double(std::count(in.begin(), in.end(), 1)) / double(in.size()));
    coarseTets = int(std::clamp(std::lround(s.coarseTets / share), long(s.coarseTets), std::max(long(s.coarseTets), std::min(8L * s.coarseTets, 10'000'000L))));
  }
  return coarseTets;
}

// The nested (or image-adapted) meshes of the region with coarseTets coarse tets.
void buildMeshes(SimScene& sc, const SimSettings& s, int coarseTets, const MaterialTable& table, const TissueMap& tissue, const ProgressFn& progress) {
  const int finePer = std::max(1, s.fineTets / std::max(1, s.coarseTets));
  if (s.fineMesh == SimSettings::FineMesh::ImageAdapted) {
    if (s.element != CoarseElement::Cell) throw Error("simulation: the image-adapted fine mesh needs cell elements");
    const auto youngsAt = [&](const Eigen::Vector3d& p) { return table.band(tissue.bandAt(p)).youngs; };
    sc.meshes = buildImageAdaptedMeshes({sc.lo, sc.hi, coarseTets, finePer, youngsAt, s.adaptContrast}, progress, &sc.adapted);
  } else {
    sc.meshes = buildNestedMeshes(sc.lo, sc.hi, coarseTets, finePer);
  }
}

}  // namespace

SimScene buildSimScene(const Volume& image, const std::vector<SimHandle>& handles, const SimSettings& s, const ProgressFn& progress) {
  if (image.empty()) throw Error("simulation: empty image");
  const VolumeGeometry& g = image.geometry();
  const auto [imgLo, imgHi] = imageWorldBox(g);
  SimScene sc;
  HandlePoints shape;
  const bool shaped = s.region == SimSettings::Region::Handles && !s.wholeVolume && !handles.empty();
  if (shaped) shape.bucketMm = std::max(1.0, g.spacing.maxCoeff());  // thick slices: one bucket a slice, so the outside is found
  auto [lo, hi] = handlesBox(image, handles, sc, shaped ? &shape : nullptr);
  if (s.wholeVolume || handles.empty()) {
    lo = imgLo;
    hi = imgHi;
  } else {
    if (!(s.paddingMm >= 0) || !std::isfinite(s.paddingMm)) throw Error("simulation: padding must be a finite length >= 0");
    lo = (lo.array() - s.paddingMm).max(imgLo.array());
    hi = (hi.array() + s.paddingMm).min(imgHi.array());
  }
  if (((hi - lo).array() <= 0).any()) throw Error("simulation: the region of interest is empty (a flat image or handles on its edge)");
  sc.lo = lo;
  sc.hi = hi;
  const int coarseTets = shaped ? shapedCoarseTets(sc, s, shape) : s.coarseTets;
  // Memory before meshing: per fine tet its 12x12 stiffness, a Hessian in the refinement and the
  // assembly's slots (~2.7 KB), with 50 % for the rounding of the element counts.
  const double fineTets = double(std::max(1, s.fineTets / std::max(1, s.coarseTets))) * coarseTets;
  checkAllocation(0, std::size_t(1.5 * std::max(fineTets, double(coarseTets)) * 2700.0), "the simulation meshes");
  reportProgress(progress, 0.0, "meshing");
  const MaterialTable table = s.materials.resolve(image);
  const TissueMap tissue(image, table, lo, hi, s.skeletonReachMm, s.bone == SimSettings::Bone::Anchored);
  buildMeshes(sc, s, coarseTets, table, tissue, progress);
  reportProgress(progress, 0.2, "materials");
  assignMaterials(sc, tissue);
  const std::vector<char> boneTet = boneTets(sc, tissue);
  if (s.outer == SimSettings::Outer::Exterior && !sc.handleCentroid.empty()) applyExteriorLayer(sc);
  reportProgress(progress, 0.5, "stiffness");
  sc.fineK = tetStiffnesses(sc.meshes.fine, sc.youngs, sc.poisson);
  std::vector<char> holdsHandle(shaped ? sc.meshes.coarseGrid.cellCount() : 0, 0);
  assignConstraints(sc, image, handles, s, shaped ? &holdsHandle : nullptr);
  if (tissue.skeletonVoxelCount() > 0) anchorSkeleton(sc, tissue, boneTet);
  if (shaped) holdCellsAwayFromHandles(sc, shape, holdsHandle, s.paddingMm);
  if (s.interface == SimSettings::Interface::Sliding && !handles.empty()) makeInterfacesSliding(sc, g, handles);
  countHandleNodes(sc, handles.size());
  reportProgress(progress, 1.0, "scene");
  return sc;
}

const char* fineMaterialName(FineMaterial m) { return m == FineMaterial::NeoHookean ? "neo-hookean" : "corotational"; }

StaticSolveResult solveFineStatic(const SimScene& sc, const std::vector<RigidTransform>& handles, StaticSolveOptions options,
                                  const std::vector<Eigen::Vector3d>* start, FineMaterial material) {
  std::vector<char> dir;
  std::vector<Eigen::Vector3d> x0 = prescribedPositions(sc.meshes.fine, sc.constraints, handles, &dir);
  if (start) {
    if (start->size() != x0.size()) throw Error("fine solve: the start has the wrong node count");
    for (std::size_t i = 0; i < x0.size(); ++i)
      if (!dir[i]) x0[i] = (*start)[i];
  }
  options.springs = slideSprings(sc.meshes.fine, sc.constraints.slide, handles);
  StaticSolveResult r = solveStatic(sc.meshes.fine, sc.fineK, dir, x0, options);
  if (material == FineMaterial::Corotational) return r;
  StaticSolveResult h = solveStaticNeoHookean(sc.meshes.fine, neoHookeanTets(sc.meshes.fine, sc.youngs, sc.poisson), dir, r.x, options);
  h.iterations += r.iterations;
  h.factorizations += r.factorizations;
  return h;
}

std::vector<Eigen::Vector3d> sampleDeformation(const SimScene& sc, const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& points) {
  const TetMesh& F = sc.meshes.fine;
  if (x.size() != F.nodes.size()) throw Error("deformation sampling: wrong node count");
  std::vector<Eigen::Vector3d> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& p = points[i];
    const int t = sc.meshes.locateFine(p);
    if (t < 0) {
      out[i] = p;
      continue;
    }
    const auto& v = F.tets[std::size_t(t)];
    Eigen::Matrix3d D;
    for (int c = 0; c < 3; ++c) D.col(c) = F.nodes[std::size_t(v[std::size_t(c + 1)])] - F.nodes[std::size_t(v[0])];
    const Eigen::Vector3d l = D.inverse() * (p - F.nodes[std::size_t(v[0])]);
    const Eigen::Vector4d w(1.0 - l.sum(), l.x(), l.y(), l.z());
    out[i] = p;
    for (int c = 0; c < 4; ++c) out[i] += w[c] * (x[std::size_t(v[std::size_t(c)])] - F.nodes[std::size_t(v[std::size_t(c)])]);
  }
  return out;
}

DeformationError compareDeformation(const SimScene& sc, const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x,
                                    const std::vector<Eigen::Vector3d>& ref) {
  const TetMesh& F = sc.meshes.fine;
  if (x.size() != F.nodes.size() || ref.size() != F.nodes.size()) throw Error("deformation error: wrong node count");
  DeformationError e;
  double motion2 = 0;
  std::size_t nh = 0, nf = 0;
  double err2 = 0, ref2 = 0;
  for (std::size_t n = 0; n < F.nodes.size(); ++n) {
    const int h = sc.constraints.handleOf[n];
    if (sc.constraints.fixed[n]) continue;
    if (h >= 0) {
      motion2 += (handles[std::size_t(h)].apply(F.nodes[n]) - F.nodes[n]).squaredNorm();
      ++nh;
      continue;
    }
    const double d = (x[n] - ref[n]).norm();
    err2 += d * d;
    e.maxOfMotion = std::max(e.maxOfMotion, d);
    ref2 += (ref[n] - F.nodes[n]).squaredNorm();
    ++nf;
  }
  e.handleMotionMm = nh ? std::sqrt(motion2 / double(nh)) : 0.0;
  const double m = std::max(e.handleMotionMm, 1e-12);
  e.rmsOfMotion = nf ? std::sqrt(err2 / double(nf)) / m : 0.0;
  e.maxOfMotion /= m;
  e.relativeL2 = ref2 > 0 ? std::sqrt(err2 / ref2) : 0.0;
  return e;
}

void countHandleNodes(SimScene& sc, std::size_t handleCount) {
  sc.handleNodeCount.assign(handleCount, 0);
  for (std::size_t n = 0; n < sc.meshes.fine.nodes.size(); ++n)
    if (sc.constraints.handleOf[n] >= 0 && !sc.constraints.fixed[n]) ++sc.handleNodeCount[std::size_t(sc.constraints.handleOf[n])];
  for (const SlideNode& sn : sc.constraints.slide) ++sc.handleNodeCount[std::size_t(sn.handle)];
}

}  // namespace handson
