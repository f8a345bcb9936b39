#include "frame_graph.h"

#include <cstdlib>
#include <cstring>
#include <sstream>

#include "graph_check.h"
#include "sim/base/error.h"

namespace handson::fg {

bool isWrite(Access a) {
  switch (a) {
    case Access::StorageWrite:
    case Access::StorageReadWrite:
    case Access::TransferDst:
    case Access::HostWrite:
    case Access::ColorAttachmentWrite: return true;
    default: return false;
  }
}

bool isRead(Access a) {
  switch (a) {
    case Access::Sampled:
    case Access::StorageRead:
    case Access::StorageReadWrite:
    case Access::UniformRead:
    case Access::TransferSrc:
    case Access::HostRead:
    case Access::Present:
    case Access::IndirectRead: return true;
    default: return false;
  }
}

Layout accessLayout(Access a) {
  switch (a) {
    case Access::None: return Layout::Undefined;
    case Access::Sampled:
    case Access::UniformRead: return Layout::ShaderReadOnly;
    case Access::TransferSrc: return Layout::TransferSrc;
    case Access::TransferDst: return Layout::TransferDst;
    case Access::Present: return Layout::PresentSrc;
    case Access::ColorAttachmentWrite: return Layout::ColorAttachment;
    default: return Layout::General;
  }
}

const char* accessName(Access a) {
  switch (a) {
    case Access::None: return "none";
    case Access::Sampled: return "sampled";
    case Access::StorageRead: return "storage-read";
    case Access::StorageWrite: return "storage-write";
    case Access::StorageReadWrite: return "storage-read-write";
    case Access::UniformRead: return "uniform-read";
    case Access::TransferSrc: return "transfer-src";
    case Access::TransferDst: return "transfer-dst";
    case Access::HostRead: return "host-read";
    case Access::HostWrite: return "host-write";
    case Access::ColorAttachmentWrite: return "color-attachment-write";
    case Access::Present: return "present";
    case Access::IndirectRead: return "indirect-read";
  }
  return "?";
}

ResourceHandle PassBuilder::read(ResourceHandle h, Access a) {
  graph_->checkHandle(h);
  if (!isRead(a)) throw Error(std::string("frame graph: '") + accessName(a) + "' is not a read access");
  uses_.push_back({h, a});
  return h;
}

ResourceHandle PassBuilder::write(ResourceHandle h, Access a) {
  graph_->checkHandle(h);
  if (!isWrite(a)) throw Error(std::string("frame graph: '") + accessName(a) + "' is not a write access");
  uses_.push_back({h, a});
  return h;
}

ResourceHandle FrameGraph::addResource(ResourceInfo info) {
  resources_.push_back(std::move(info));
  compiledOk_ = false;
  return ResourceHandle{static_cast<std::uint32_t>(resources_.size() - 1)};
}

namespace {
ResourceInfo makeResource(std::string name, ResourceKind kind, const ImageDesc& image, const BufferDesc& buffer, bool imported,
                          Access currentAccess) {
  ResourceInfo r;
  r.name = std::move(name);
  r.kind = kind;
  r.image = image;
  r.buffer = buffer;
  r.imported = imported;
  r.initialAccess = currentAccess;
  return r;
}
}  // namespace

ResourceHandle FrameGraph::importImage(std::string name, const ImageDesc& desc, Access currentAccess, const void* external) {
  ResourceInfo r = makeResource(std::move(name), ResourceKind::Image, desc, {}, true, currentAccess);
  r.external = external;
  return addResource(std::move(r));
}

ResourceHandle FrameGraph::importBuffer(std::string name, const BufferDesc& desc, Access currentAccess, const void* external) {
  ResourceInfo r = makeResource(std::move(name), ResourceKind::Buffer, {}, desc, true, currentAccess);
  r.external = external;
  return addResource(std::move(r));
}

ResourceHandle FrameGraph::createImage(std::string name, const ImageDesc& desc) {
  return addResource(makeResource(std::move(name), ResourceKind::Image, desc, {}, false, Access::None));
}

ResourceHandle FrameGraph::createBuffer(std::string name, const BufferDesc& desc) {
  return addResource(makeResource(std::move(name), ResourceKind::Buffer, {}, desc, false, Access::None));
}

void FrameGraph::checkHandle(ResourceHandle h) const {
  if (!h.valid() || h.id >= resources_.size()) throw Error("frame graph: unknown resource handle");
}

const ResourceInfo& FrameGraph::resource(ResourceHandle h) const {
  checkHandle(h);
  return resources_[h.id];
}

void FrameGraph::addPass(PassId id, const SetupFn& setup, ExecuteFn execute) {
  addPass(std::string(handson::passName(id)), setup, std::move(execute));
  passes_.back().id = id;
}

void FrameGraph::addPass(std::string name, const SetupFn& setup, ExecuteFn execute) {
  PassBuilder builder;
  builder.graph_ = this;
  if (setup) setup(builder);
  Pass p;
  p.name = std::move(name);
  p.uses = std::move(builder.uses_);
  p.sideEffect = builder.sideEffect_;
  p.execute = std::move(execute);
  passes_.push_back(std::move(p));
  compiledOk_ = false;
}

void FrameGraph::exportResource(ResourceHandle h, Access finalAccess) {
  checkHandle(h);
  resources_[h.id].exported = true;
  resources_[h.id].finalAccess = finalAccess;
  compiledOk_ = false;
}

bool FrameGraph::isCulled(std::uint32_t passIndex) const { return passes_.at(passIndex).culled; }

Access FrameGraph::stateAfterFrame(ResourceHandle h) const {
  checkHandle(h);
  if (!compiledOk_) throw Error("frame graph: not compiled");
  return endState_[h.id];
}

namespace {

// Synchronization state of one resource while walking the passes in execution order.
struct Tracker {
  AccessMask lastWrite = 0;        // the most recent write (0 or one bit)
  AccessMask readsSinceWrite = 0;  // reads issued after that write
  AccessMask visibleTo = 0;        // read accesses that already saw the last write (a barrier made it visible)
  Layout layout = Layout::Undefined;
  Access last = Access::None;
  bool written = false;  // anything defined the contents (a write, or it was imported)
};

// Computes the barrier (if any) that must precede `a` on resource `r`, and updates the tracker.
bool transition(Tracker& t, bool isImage, ResourceHandle r, Access a, Barrier& out) {
  const Layout need = isImage ? accessLayout(a) : Layout::General;
  const bool layoutChange = isImage && t.layout != need;
  out = Barrier{r, 0, a, t.layout, need};
  bool emit = false;
  if (isWrite(a)) {
    // Write after read: wait for the reads (execution dependency). Write after write: wait for
    // and make available the previous write.
    out.src = t.readsSinceWrite ? (t.readsSinceWrite | t.lastWrite) : t.lastWrite;
    emit = out.src != 0 || layoutChange;
    t.lastWrite = accessBit(a);
    t.readsSinceWrite = isRead(a) ? accessBit(a) : 0;
    t.visibleTo = isRead(a) ? accessBit(a) : 0;
    t.written = true;
  } else {
    if (layoutChange) {
      // A layout transition is itself a write: it must wait for everything before it.
      out.src = t.lastWrite | t.readsSinceWrite;
      emit = true;
      t.visibleTo = accessBit(a);
    } else if (t.lastWrite && !(t.visibleTo & accessBit(a))) {
      out.src = t.lastWrite;
      emit = true;
      t.visibleTo |= accessBit(a);
    }
    t.readsSinceWrite |= accessBit(a);
  }
  t.layout = need;
  t.last = a;
  return emit;
}

}  // namespace

void FrameGraph::compile() {
  compiled_.clear();
  final_.clear();
  compiledOk_ = false;

  // 1. Culling, from the last pass backwards: a pass survives if it has side effects, writes an
  //    imported or exported resource, or writes something a surviving later pass reads.
  std::vector<char> needed(resources_.size(), 0);
  for (std::size_t i = 0; i < resources_.size(); ++i) needed[i] = resources_[i].exported || resources_[i].imported;
  for (std::size_t pi = passes_.size(); pi-- > 0;) {
    Pass& p = passes_[pi];
    bool alive = p.sideEffect;
    for (const auto& u : p.uses)
      if (isWrite(u.access) && needed[u.resource.id]) alive = true;
    p.culled = !alive;
    if (!alive) continue;
    for (const auto& u : p.uses)
      if (isRead(u.access)) needed[u.resource.id] = 1;
  }

  // 2. Order: declaration order of the survivors (declaration order is a valid topological order
  //    because a pass can only reference resources declared before it). 3. Barriers.
  std::vector<Tracker> track(resources_.size());
  for (std::size_t i = 0; i < resources_.size(); ++i) {
    const ResourceInfo& r = resources_[i];
    if (!r.imported) continue;
    Tracker& t = track[i];
    t.written = true;
    t.layout = r.kind == ResourceKind::Image ? accessLayout(r.initialAccess) : Layout::General;
    // Work of an earlier submission on the same queue may still be running: be conservative.
    if (isWrite(r.initialAccess)) t.lastWrite = accessBit(r.initialAccess);
    else if (isRead(r.initialAccess)) t.readsSinceWrite = accessBit(r.initialAccess);
    t.last = r.initialAccess;
  }
  for (std::uint32_t pi = 0; pi < passes_.size(); ++pi) {
    const Pass& p = passes_[pi];
    if (p.culled) continue;
    CompiledPass cp{pi, {}};
    for (const auto& u : p.uses) {
      Tracker& t = track[u.resource.id];
      const ResourceInfo& r = resources_[u.resource.id];
      if (isRead(u.access) && !t.written) {
        std::ostringstream msg;
        msg << "frame graph: pass '" << p.name << "' reads '" << r.name << "' before any pass writes it";
        throw Error(msg.str());
      }
      Barrier b;
      if (transition(t, r.kind == ResourceKind::Image, u.resource, u.access, b)) {
        // Merge with a barrier already queued for this resource in this pass (e.g. read + write).
        bool merged = false;
        for (auto& e : cp.barriers)
          if (e.resource == b.resource) {
            e.src |= b.src;
            e.dstAlso |= accessBit(e.dst);  // every use of the pass waits for the barrier
            e.dst = u.access;               // the later use of the same pass decides the layout and state
            e.newLayout = b.newLayout;
            merged = true;
          }
        if (!merged) cp.barriers.push_back(b);
      }
    }
    compiled_.push_back(std::move(cp));
  }
  for (std::uint32_t i = 0; i < resources_.size(); ++i) {
    const ResourceInfo& r = resources_[i];
    if (!r.exported || r.finalAccess == Access::None) continue;
    Tracker& t = track[i];
    if (!t.written) continue;  // nothing produced it this frame; leave it alone
    Barrier b;
    if (transition(t, r.kind == ResourceKind::Image, ResourceHandle{i}, r.finalAccess, b)) final_.push_back(b);
  }
  endState_.assign(resources_.size(), Access::None);
  for (std::size_t i = 0; i < resources_.size(); ++i) endState_[i] = track[i].last;
  compiledOk_ = true;
  if (checkBarriersOnCompile()) {
    const std::vector<std::string> problems = barrierProblems(traceOf(*this));
    if (!problems.empty())
      throw Error("frame graph: its barriers leave a use uncovered: " + problems.front() +
                  (problems.size() > 1 ? " (and " + std::to_string(problems.size() - 1) + " more)" : std::string()));
  }
}

bool checkBarriersOnCompile() {
#ifndef NDEBUG
  return true;
#else
  static const bool on = [] {
    const char* v = std::getenv("HANDSON_CHECK_GRAPH");
    return v && std::strcmp(v, "1") == 0;
  }();
  return on;
#endif
}

void FrameGraph::execute(Executor& executor) {
  if (!compiledOk_) throw Error("frame graph: execute() before compile()");
  std::vector<char> realized(resources_.size(), 0);
  for (const auto& cp : compiled_)
    for (const auto& u : passes_[cp.pass].uses)
      if (!resources_[u.resource.id].imported && !realized[u.resource.id]) {
        realized[u.resource.id] = 1;
        executor.realizeTransient(u.resource, resources_[u.resource.id]);
      }
  for (const auto& cp : compiled_) {
    const Pass& p = passes_[cp.pass];
    const PassInfo info{cp.pass, p.name, p.id};
    executor.beginPass(info);
    if (!cp.barriers.empty()) executor.barriers(cp.barriers);
    if (p.execute) p.execute(executor);
    executor.endPass(info);
  }
  if (!final_.empty()) executor.finalBarriers(final_);
}

}  // namespace handson::fg
