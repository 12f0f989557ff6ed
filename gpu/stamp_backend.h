// Stamp backends behind one interface: the CPU reference (protocol/stamps/stamp_apply.h) and
// the GPU stamper (gpu_stamper.h) through headless EGL. Both give exactly the same integers,
// the same changed rect and the same dirty marks, so the server, the client and replay can
// use either; make_stamp_backend picks one by the rule of backend_choice.h and logs the choice
// and the GL renderer.
//
// A backend is bound to one World's parameters (the GPU keeps a copy of its layers). Who
// changes that World other than through apply() (regions, snapshots) must call
// world_changed() for the rect, so the GPU copy follows. Calls may come from any thread, one
// at a time (the GPU backend's context is current only during a call).
#pragma once

#include <memory>
#include <string>

#include "gpu/backend_choice.h"
#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {
class World;
}

namespace loam::gpu {

class StampBackend {
 public:
  virtual ~StampBackend() = default;
  // "cpu" or "gpu".
  virtual const char* name() const = 0;
  // What runs it: "CPU reference", or the GL renderer string.
  virtual std::string renderer() const = 0;
  // As loam::apply_stamp: validates q (check_quantized), applies it to `world` (which must be
  // the World the backend was made for), marks the changed samples dirty and returns their
  // bounding rect in the layer's global sample grid. The caller commits. On error the world
  // is unchanged.
  virtual Result<RectI> apply(World& world, const QuantizedStamp& q) = 0;
  // The World changed outside apply() over `rect` of `layer`.
  virtual void world_changed(World& world, Layer layer, const RectI& rect) = 0;
};

// Makes the backend `kind` asks for (see backend_choice.h) for `world`. `textures` (may be
// null) must outlive the backend. Logs "stamp backend: <choice> (<renderer>)" to stderr.
// Errors: kGpu where no EGL display gives an OpenGL 4.5 core context, or where the GPU
// stamper cannot be set up.
Result<std::unique_ptr<StampBackend>> make_stamp_backend(BackendKind kind, const World& world,
                                                         const TextureRegistry* textures = nullptr,
                                                         const StampLimits& limits = {});

}  // namespace loam::gpu
