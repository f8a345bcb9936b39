#pragma once
// An independent check of a compiled frame graph's barriers: it walks the passes in execution
// order with their barriers, tracking each resource's accesses since its last write and its image
// layout, and reports every use the barriers before it leave uncovered:
// - a read of contents whose last write no barrier made visible to that read's access;
// - a write that no barrier ordered after an earlier read or write of the resource;
// - an image used in a layout other than its access needs, a transition from a layout the image is
//   not in, a transition whose source scope misses an earlier access (the transition is a write),
//   or one from Undefined that discards written contents.
// It knows the graph's abstract accesses, not a GPU API, and shares no code with the graph's own
// barrier placement (frame_graph.cpp), so the two check each other; the Vulkan side (stages, access
// masks) is checked by the validation layer's synchronization validation in the GPU tests.
#include <string>
#include <vector>

#include "frame_graph.h"

namespace handson::fg {

/// One executed pass: its barriers (recorded before it) and its declared uses.
struct GraphStep {
  std::string pass;
  std::vector<Barrier> barriers;
  std::vector<PassBuilder::Use> uses;
};

/// What the check reads: the resources, the executed passes in order, the final barriers.
struct GraphTrace {
  std::vector<ResourceInfo> resources;
  std::vector<GraphStep> steps;
  std::vector<Barrier> finalBarriers;
};

/// The trace of a compiled graph (throws handson::Error if it was not compiled).
GraphTrace traceOf(const FrameGraph& graph);

/// Every uncovered use, one line each ("pass 'copy' reads 'color' (transfer-src) ..."); empty when
/// the barriers cover every use.
std::vector<std::string> barrierProblems(const GraphTrace& trace);

}  // namespace handson::fg
