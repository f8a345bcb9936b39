#include "graph_check.h"

#include <algorithm>

#include "sim/base/error.h"

namespace handson::fg {

GraphTrace traceOf(const FrameGraph& graph) {
  GraphTrace t;
  for (std::uint32_t i = 0; i < graph.resourceCount(); ++i) t.resources.push_back(graph.resource(ResourceHandle{i}));
  for (const auto& cp : graph.compiled()) t.steps.push_back({graph.passName(cp.pass), cp.barriers, graph.passUses(cp.pass)});
  t.finalBarriers = graph.finalBarriers();
  return t;
}

namespace {

// One access since the resource's last write (that write first), and the later accesses a
// barrier has ordered it before (and, for a write, made its results visible to).
struct Event {
  Access access = Access::None;  // None: a layout transition
  AccessMask orderedFor = 0;
  bool write = false;
};

struct ResourceState {
  std::vector<Event> since;
  Layout layout = Layout::Undefined;
};

const char* layoutName(Layout l) {
  switch (l) {
    case Layout::Undefined: return "undefined";
    case Layout::General: return "general";
    case Layout::ShaderReadOnly: return "shader-read-only";
    case Layout::TransferSrc: return "transfer-src";
    case Layout::TransferDst: return "transfer-dst";
    case Layout::ColorAttachment: return "color-attachment";
    case Layout::PresentSrc: return "present-src";
  }
  return "?";
}

std::string eventName(const Event& e) { return e.access == Access::None ? std::string("a layout transition") : std::string(accessName(e.access)); }

class Checker {
 public:
  explicit Checker(const GraphTrace& t) : trace_(t), state_(t.resources.size()) {
    for (std::size_t i = 0; i < t.resources.size(); ++i) {
      const ResourceInfo& r = t.resources[i];
      if (!r.imported) continue;
      // An earlier submission's access may still run: it counts as unordered.
      if (r.initialAccess != Access::None) state_[i].since.push_back({r.initialAccess, 0, isWrite(r.initialAccess)});
      state_[i].layout = isImage(i) ? accessLayout(r.initialAccess) : Layout::General;
    }
  }

  std::vector<std::string> run() {
    for (const GraphStep& s : trace_.steps) step(s.pass, s.barriers, s.uses);
    std::vector<PassBuilder::Use> finals;
    for (std::uint32_t i = 0; i < trace_.resources.size(); ++i) {
      const ResourceInfo& r = trace_.resources[i];
      if (r.exported && r.finalAccess != Access::None && (r.imported || !state_[i].since.empty())) finals.push_back({ResourceHandle{i}, r.finalAccess});
    }
    step("(end of frame)", trace_.finalBarriers, finals, false);
    return problems_;
  }

 private:
  bool isImage(std::size_t r) const { return trace_.resources[r].kind == ResourceKind::Image; }

  void problem(const std::string& pass, std::size_t r, const std::string& what) {
    problems_.push_back("pass '" + pass + "', '" + trace_.resources[r].name + "': " + what);
  }

  // The barriers first, then every use against the accesses of earlier passes, then the pass's own.
  void step(const std::string& pass, const std::vector<Barrier>& barriers, const std::vector<PassBuilder::Use>& uses, bool record = true) {
    for (const Barrier& b : barriers) applyBarrier(pass, b);
    for (const auto& u : uses) checkUse(pass, u);
    if (!record) return;
    for (const auto& u : uses) {
      ResourceState& s = state_[u.resource.id];
      if (isWrite(u.access)) s.since.assign(1, {u.access, 0, true});
      else s.since.push_back({u.access, 0, false});
    }
  }

  void applyBarrier(const std::string& pass, const Barrier& b) {
    const std::size_t r = b.resource.id;
    if (r >= state_.size()) return problem(pass, 0, "a barrier on an unknown resource");
    ResourceState& s = state_[r];
    const AccessMask dst = accessBit(b.dst) | b.dstAlso;
    if (isImage(r) && b.oldLayout != b.newLayout) {
      const bool written = std::any_of(s.since.begin(), s.since.end(), [](const Event& e) { return e.write; });
      if (b.oldLayout == Layout::Undefined && written) problem(pass, r, "a transition from undefined discards what was written");
      else if (b.oldLayout != Layout::Undefined && b.oldLayout != s.layout)
        problem(pass, r, std::string("a transition from ") + layoutName(b.oldLayout) + " but the image is " + layoutName(s.layout));
      for (const Event& e : s.since)
        if (e.access != Access::None && !(accessBit(e.access) & b.src)) problem(pass, r, "the layout transition does not wait for " + eventName(e));
      s.layout = b.newLayout;
      s.since.assign(1, {Access::None, dst, true});
      return;
    }
    if (isImage(r) && b.newLayout != s.layout && b.newLayout != Layout::Undefined)
      problem(pass, r, std::string("a barrier in layout ") + layoutName(b.newLayout) + " but the image is " + layoutName(s.layout));
    for (Event& e : s.since)
      if (e.access != Access::None && (accessBit(e.access) & b.src)) e.orderedFor |= dst;
  }

  void checkUse(const std::string& pass, const PassBuilder::Use& u) {
    const std::size_t r = u.resource.id;
    ResourceState& s = state_[r];
    if (isImage(r) && s.layout != accessLayout(u.access))
      problem(pass, r, std::string(accessName(u.access)) + " needs layout " + layoutName(accessLayout(u.access)) + ", the image is " + layoutName(s.layout));
    const AccessMask bit = accessBit(u.access);
    for (const Event& e : s.since) {
      if (e.orderedFor & bit) continue;
      if (isWrite(u.access)) problem(pass, r, std::string(accessName(u.access)) + " is not ordered after " + eventName(e));
      else if (e.write) problem(pass, r, std::string(accessName(u.access)) + " does not see " + eventName(e) + " (no barrier made it visible)");
    }
  }

  const GraphTrace& trace_;
  std::vector<ResourceState> state_;
  std::vector<std::string> problems_;
};

}  // namespace

std::vector<std::string> barrierProblems(const GraphTrace& trace) { return Checker(trace).run(); }

}  // namespace handson::fg
