#include "pass_resources.h"

#include "vk_graph_executor.h"
#include "vk_resources.h"

namespace handson::vk {

PassResources& PassResources::buffer(std::uint32_t binding, fg::ResourceHandle h, fg::Access access) {
  entries_.push_back({Kind::Buffer, binding, h, access, VK_NULL_HANDLE});
  return *this;
}

PassResources& PassResources::sampled(std::uint32_t binding, fg::ResourceHandle h, const Sampler& sampler) {
  entries_.push_back({Kind::Sampled, binding, h, fg::Access::Sampled, sampler.handle()});
  return *this;
}

PassResources& PassResources::storageImage(std::uint32_t binding, fg::ResourceHandle h, fg::Access access) {
  entries_.push_back({Kind::StorageImage, binding, h, access, VK_NULL_HANDLE});
  return *this;
}

PassResources& PassResources::use(fg::ResourceHandle h, fg::Access access) {
  entries_.push_back({Kind::UseOnly, 0, h, access, VK_NULL_HANDLE});
  return *this;
}

void PassResources::declare(fg::PassBuilder& b) const {
  for (const Entry& e : entries_) {
    if (fg::isWrite(e.access)) b.write(e.handle, e.access);
    else b.read(e.handle, e.access);
  }
}

void PassResources::push(const Context& ctx, const GraphExecutor& x, const ComputePipeline& pipeline) const {
  DescriptorWriter w;
  for (const Entry& e : entries_) {
    switch (e.kind) {
      case Kind::Buffer: w.buffer(e.binding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, x.buffer(e.handle).handle()); break;
      case Kind::Sampled: w.sampledImage(e.binding, x.image(e.handle).view(), e.sampler, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL); break;
      case Kind::StorageImage: w.storageImage(e.binding, x.image(e.handle).view()); break;
      case Kind::UseOnly: break;
    }
  }
  w.push(ctx, x.cmd(), pipeline);
}

}  // namespace handson::vk
