// The GPU stamp backend's engine: a GPU copy of a World's mip-0 layers, stamped in compute
// shaders that reproduce the CPU reference (protocol/stamps/) bit for bit, with the changed
// samples read back asynchronously into the World (the CPU mirror).
//
// Resources: one R16UI texture of the whole coarse layer and one R8I texture of the whole
// detail layer (mip 0; mips, hashes and versions stay with World::commit on the mirror),
// uploaded once at creation. A stamp bakes its per-stamp constants on the CPU (bake_stamp,
// the same code as the reference), then dispatches over the stamp's rect only and updates
// the texels in place with image load/store; texture stamps are read with texelFetch and
// integer weights. Shockwaves ping-pong a wave field in two storage buffers.
//
// Readback: submit() queues a read of the stamp's rect into a pixel buffer object plus a
// fence and returns at once; collect() waits for the fences in order, maps each buffer,
// finds the changed rect by comparing with the mirror (which holds the state before that
// stamp; per-sample atomics in the shader serialize on llvmpipe) and writes it into the World
// through write_coarse / write_detail (which mark exactly the changed samples dirty). The World is only ever written by collect(), on the caller's
// thread, after the transfer into the buffer has completed, so the mirror is never read or
// written while a transfer is in flight; between submit() and collect() the mirror is simply
// older than the GPU copy. apply() is submit + collect: the reference's contract.
//
// Needs the GL 4.5 context it was created in to be current on the calling thread. Not
// thread-safe.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "gpu/gl_handle.h"
#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {
class World;
}

namespace loam::gpu {

// One completed readback: the samples of `layer` that changed (global layer sample rect).
struct StampReadback {
  uint64_t ticket = 0;
  Layer layer = Layer::kCoarse;
  RectI changed;
};

class GpuStamper {
 public:
  // Uploads both layers of `world`. `textures` (may be null) must outlive the stamper.
  // Errors: a layer larger than GL_MAX_TEXTURE_SIZE, a shader that does not build.
  static Result<std::unique_ptr<GpuStamper>> create(const World& world,
                                                    const TextureRegistry* textures = nullptr,
                                                    const StampLimits& limits = {});
  ~GpuStamper();
  GpuStamper(const GpuStamper&) = delete;
  GpuStamper& operator=(const GpuStamper&) = delete;

  // Validates q (check_quantized), stamps the GPU copy and queues the readback of its rect.
  // Returns a ticket (increasing). On error nothing was changed.
  Result<uint64_t> submit(const QuantizedStamp& q);
  // Waits for every queued readback, oldest first, and writes the changed samples into
  // `world` (marking them dirty; the caller commits). Returns one entry per ticket.
  std::vector<StampReadback> collect(World& world);
  size_t pending() const { return pending_.size(); }

  // The CPU reference's contract (apply_stamp): apply q to the GPU copy and the mirror,
  // return the bounding rect of the samples that changed (empty: none).
  Result<RectI> apply(World& world, const QuantizedStamp& q);

  // Re-uploads a rect of a layer from the mirror, after the World changed outside the
  // stamper (a region from the server, a snapshot). Collects first.
  void upload(World& world, Layer layer, const RectI& rect);

  // Reads a rect of the GPU copy synchronously (tests and benchmarks; stalls the pipeline).
  std::vector<int32_t> read_gpu(Layer layer, const RectI& rect);

  // The GPU copy of a layer (R16UI coarse, R8I detail), texel (0, 0) = the layer's first
  // sample; for the normal pass and the client's renderer.
  GLuint texture(Layer layer) const { return layer == Layer::kCoarse ? coarse_.get() : detail_.get(); }
  RectI layer_rect(Layer layer) const { return layer == Layer::kCoarse ? coarse_rect_ : detail_rect_; }

 private:
  GpuStamper() = default;
  struct Pending {
    uint64_t ticket = 0;
    Layer layer = Layer::kCoarse;
    RectI rect;  // read back, global layer samples
    size_t pixel_bytes = 0;
    GlBuffer pbo;
    size_t capacity = 0;
    GlSync fence;
  };
  Result<GLuint> program(const std::string& key, const std::string& file, int kind, Layer layer);
  Status stamp_per_sample(const QuantizedStamp& q, RectI& readback);
  Status stamp_shockwave(const QuantizedStamp& q, RectI& readback);
  void reset_result();
  void queue_readback(Layer layer, const RectI& rect);
  Status texture_for(uint64_t id, GLuint& out);

  const TextureRegistry* textures_ = nullptr;
  StampLimits limits_;
  WorldParams params_;
  RectI coarse_rect_, detail_rect_;
  GlTexture coarse_, detail_;
  GlBuffer params_buf_, result_buf_, wave_a_, wave_b_;
  size_t wave_capacity_ = 0;
  std::map<std::string, GlProgram> programs_;
  std::unordered_map<uint64_t, GlTexture> stamp_textures_;
  std::deque<Pending> pending_;
  std::vector<Pending> free_pbos_;
  uint64_t next_ticket_ = 1;
};

}  // namespace loam::gpu
