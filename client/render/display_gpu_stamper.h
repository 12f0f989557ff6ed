// The display's GPU tile cache: gpu::GpuStamper behind the DisplayStamper interface. Needs the
// GL 4.5 context current for every call.
#pragma once

#include "client/terrain/display_stamper.h"
#include "gpu/gpu_stamper.h"

namespace loam::render {

terrain::DisplayStamperFactory gpu_display_stamper(gpu::GpuStamperOptions options = {});

}  // namespace loam::render
