#pragma once
// A frame graph for compute work: passes declare the images (2D or 3D) and buffers they read and
// write; compile() culls passes whose outputs nobody uses, orders the rest, and places the memory
// barriers and image layout transitions between them. The graph never touches a GPU API: it drives
// an injected Executor (Vulkan in vk_graph_executor.h, a recording mock in the tests), so its
// ordering, culling and barrier logic are tested without a GPU.
//
// Usage:
//   FrameGraph g;
//   auto vol = g.importImage("volume", {...}, Access::Sampled);          // persistent, in layout of Sampled
//   auto out = g.createImage("color", {w, h, 1, Format::Rgba8Unorm});   // transient, backend allocates
//   g.addPass(PassId::Raymarch, [&](PassBuilder& b) { b.read(vol, Access::Sampled); b.write(out, Access::StorageWrite); },
//             [&](Executor& e) { ... record ... });
//   g.exportResource(out, Access::TransferSrc);   // keeps its producers alive, final state
//   g.compile(); g.execute(executor);
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "render/pass_id.h"

namespace handson::fg {

enum class Format : std::uint8_t { R8Unorm, R16Unorm, R16Sfloat, R32Sfloat, R32Uint, Rgba8Unorm, Rgba16Sfloat, Rgba32Sfloat };

/// How a pass (or the host) touches a resource. Each maps to one pipeline stage, access mask and,
/// for images, one layout (see accessLayout()).
enum class Access : std::uint8_t {
  None,          ///< not yet touched this frame (initial state of a transient resource)
  Sampled,       ///< read through a sampler in a compute shader
  StorageRead,   ///< imageLoad / storage-buffer read in a compute shader
  StorageWrite,  ///< imageStore / storage-buffer write (no read of the old contents)
  StorageReadWrite,
  UniformRead,
  TransferSrc,
  TransferDst,
  HostRead,  ///< mapped and read by the CPU after the frame's fence
  HostWrite,
  ColorAttachmentWrite,  ///< drawn by a render pass (the UI overlay), loading the old contents
  Present,  ///< swapchain image handed to the presentation engine
  IndirectRead,  ///< buffer read as indirect dispatch arguments
};
constexpr unsigned kAccessCount = unsigned(Access::IndirectRead) + 1;

enum class Layout : std::uint8_t { Undefined, General, ShaderReadOnly, TransferSrc, TransferDst, ColorAttachment, PresentSrc };

bool isWrite(Access a);
bool isRead(Access a);
/// Image layout an access needs (General for buffers too; ignored there).
Layout accessLayout(Access a);
const char* accessName(Access a);

struct ImageDesc {
  std::uint32_t width = 1, height = 1, depth = 1;
  Format format = Format::Rgba8Unorm;
};
struct BufferDesc {
  std::uint64_t size = 0;
};

struct ResourceHandle {
  std::uint32_t id = UINT32_MAX;
  bool valid() const { return id != UINT32_MAX; }
  friend bool operator==(ResourceHandle a, ResourceHandle b) { return a.id == b.id; }
};

enum class ResourceKind : std::uint8_t { Image, Buffer };

struct ResourceInfo {
  std::string name;
  ResourceKind kind = ResourceKind::Image;
  ImageDesc image;
  BufferDesc buffer;
  bool imported = false;        ///< owned outside the graph (persistent across frames)
  /// What an import names, for the executor to bind (opaque here: the Vulkan backend's
  /// vk::importImage / vk::importBuffer set it, so an import is bound where it is declared).
  const void* external = nullptr;
  Access initialAccess = Access::None;  ///< state an imported resource is in when the frame starts
  bool exported = false;
  Access finalAccess = Access::None;  ///< state requested at the end of the frame (exported only)
};

/// A set of accesses, one bit per Access value.
using AccessMask = std::uint32_t;
constexpr AccessMask accessBit(Access a) { return a == Access::None ? 0u : (1u << static_cast<unsigned>(a)); }

/// One memory dependency (and optional layout transition) on one resource.
struct Barrier {
  ResourceHandle resource;
  AccessMask src = 0;  ///< previous accesses to wait for (0: none, e.g. a first use)
  Access dst = Access::None;  ///< the pass's last access (the layout's and the state's)
  Layout oldLayout = Layout::Undefined;
  Layout newLayout = Layout::Undefined;
  AccessMask dstAlso = 0;  ///< the pass's other accesses after the barrier (a buffer read as indirect arguments and as storage)
};

struct PassInfo {
  std::uint32_t index = 0;  ///< declaration index
  std::string name;
  PassId id = PassId::Unnamed;
};

/// Backend interface. The graph calls these in order during execute().
class Executor {
 public:
  virtual ~Executor() = default;
  /// Called once per compile for each transient resource used by a surviving pass.
  virtual void realizeTransient(ResourceHandle handle, const ResourceInfo& info) = 0;
  virtual void beginPass(const PassInfo& pass) = 0;
  /// All barriers needed before a pass, merged into one call (possibly empty: not called then).
  virtual void barriers(const std::vector<Barrier>& list) = 0;
  virtual void endPass(const PassInfo& pass) = 0;
  /// Barriers after the last pass, bringing exported resources to their final access.
  virtual void finalBarriers(const std::vector<Barrier>& list) = 0;
};

class FrameGraph;

/// Whether compile() checks its barriers (graph_check.h): debug builds, or HANDSON_CHECK_GRAPH=1.
bool checkBarriersOnCompile();

class PassBuilder {
 public:
  /// One declared use of a resource by a pass.
  struct Use {
    ResourceHandle resource;
    Access access;
  };
  /// Declares a read; returns the same handle for chaining.
  ResourceHandle read(ResourceHandle h, Access a);
  /// Declares a write (StorageWrite, StorageReadWrite, TransferDst, HostWrite).
  ResourceHandle write(ResourceHandle h, Access a);
  /// A pass with side effects (e.g. host-visible readback) is never culled.
  void sideEffect() { sideEffect_ = true; }

 private:
  friend class FrameGraph;
  FrameGraph* graph_ = nullptr;
  std::vector<Use> uses_;
  bool sideEffect_ = false;
};

class FrameGraph {
 public:
  using SetupFn = std::function<void(PassBuilder&)>;
  using ExecuteFn = std::function<void(Executor&)>;

  ResourceHandle importImage(std::string name, const ImageDesc& desc, Access currentAccess, const void* external = nullptr);
  ResourceHandle importBuffer(std::string name, const BufferDesc& desc, Access currentAccess, const void* external = nullptr);
  ResourceHandle createImage(std::string name, const ImageDesc& desc);
  ResourceHandle createBuffer(std::string name, const BufferDesc& desc);

  /// A pass of the renderer, by its id (its name from pass_id.h's table).
  void addPass(PassId id, const SetupFn& setup, ExecuteFn execute);
  /// A pass by name alone (tests, one-off tools): its id is PassId::Unnamed.
  void addPass(std::string name, const SetupFn& setup, ExecuteFn execute);
  /// Marks a resource as a frame output: its producers survive culling, and it ends the frame in
  /// `finalAccess`.
  void exportResource(ResourceHandle h, Access finalAccess);

  /// Culls, orders and computes barriers. Throws handson::Error on misuse (unknown handle, a
  /// transient resource read before anything wrote it, a read-only access declared as a write).
  /// In debug builds and with HANDSON_CHECK_GRAPH=1 (the tests) the barriers are then checked by
  /// an independent walk (graph_check.h), and a use they leave uncovered throws.
  void compile();
  /// Runs the compiled passes on `executor`. compile() must have been called.
  void execute(Executor& executor);

  // Introspection, for tests and the timing log.
  struct CompiledPass {
    std::uint32_t pass;  ///< declaration index
    std::vector<Barrier> barriers;
  };
  const std::vector<CompiledPass>& compiled() const { return compiled_; }
  const std::vector<Barrier>& finalBarriers() const { return final_; }
  bool isCulled(std::uint32_t passIndex) const;
  const std::string& passName(std::uint32_t passIndex) const { return passes_.at(passIndex).name; }
  const ResourceInfo& resource(ResourceHandle h) const;
  std::size_t resourceCount() const { return resources_.size(); }
  std::size_t passCount() const { return passes_.size(); }
  /// The resources a pass declared, in declaration order.
  const std::vector<PassBuilder::Use>& passUses(std::uint32_t passIndex) const { return passes_.at(passIndex).uses; }
  /// Access state of a resource after the last executed frame (for imported resources: feed it
  /// back as currentAccess when importing next frame).
  Access stateAfterFrame(ResourceHandle h) const;

 private:
  friend class PassBuilder;
  struct Pass {
    std::string name;
    PassId id = PassId::Unnamed;
    std::vector<PassBuilder::Use> uses;
    ExecuteFn execute;
    bool sideEffect = false;
    bool culled = false;
  };
  ResourceHandle addResource(ResourceInfo info);
  void checkHandle(ResourceHandle h) const;

  std::vector<ResourceInfo> resources_;
  std::vector<Pass> passes_;
  std::vector<CompiledPass> compiled_;
  std::vector<Barrier> final_;
  std::vector<Access> endState_;
  bool compiledOk_ = false;
};

}  // namespace handson::fg
