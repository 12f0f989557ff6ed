// The GPU stamp backend's engine: a GPU copy of a World's mip-0 layers, stamped in shaders
// that reproduce the CPU reference (protocol/stamps/) bit for bit, with the changed samples
// read back asynchronously into the World (the CPU mirror).
//
// Resources: one R16UI texture of the whole coarse layer and one R8I texture of the whole
// detail layer (mip 0; mips, hashes and versions stay with World::commit on the mirror),
// uploaded once at creation. A stamp bakes its per-stamp constants on the CPU (bake_stamp,
// the same code as the reference) into a uniform block, then runs the per-sample kernel
// (shaders/stamp_common.glsl) over the stamp's rect only and updates the texels in place
// with image stores; texture stamps are read with texelFetch and integer weights.
// Shockwaves ping-pong a wave field in two storage buffers.
//
// Where the kernel runs (StampPath): a compute shader, or, for small stamps on a software
// renderer, a vertex shader drawing points that are clipped away. llvmpipe hands every
// compute dispatch to its worker threads and waits for them; on a machine whose idle cores
// take tens of microseconds to wake, that hand-off alone costs more than a whole small stamp
// on the CPU, while the vertex stage runs on the calling thread. The vertex pass reads the
// old samples from a copy of the rect (a vertex may be shaded twice; the pass must be
// idempotent). Both passes share the kernel, and both are checked against the reference.
//
// Readback: submit() queues a read of the stamp's rect into a pixel buffer object plus a
// fence and returns at once; collect() waits for the fences in order, maps each buffer,
// compares it with the mirror (which holds the state before that stamp; per-sample atomics
// in the shader would serialize on llvmpipe) and writes the samples that differ straight
// into the World's tiles, marking exactly the changed rect of each tile dirty. The World is
// only ever written by collect(), on the caller's thread, after the transfer into the
// buffer has completed, so the mirror is never read or written while a transfer is in
// flight; between submit() and collect() the mirror is simply older than the GPU copy.
// apply() is submit + collect: the reference's contract.
//
// Needs the GL 4.5 context it was created in to be current on the calling thread. Not
// thread-safe. A vertex-path stamp binds its own empty framebuffer and vertex array for the
// draw and restores the caller's; like every stamp it leaves its program, uniform block,
// storage buffers, image units and texture unit 0 bound.
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

// Which shader stage runs the per-sample kinds (shockwaves always run in compute).
enum class StampPath {
  kAuto,     // the vertex stage for rects of at most kVertexPathMaxSamples on a software
             // renderer that has vertex image stores; compute otherwise
  kCompute,  // always compute
  kVertex,   // always the vertex stage (tests); create() fails where it is unavailable
};

struct GpuStamperOptions {
  StampPath path = StampPath::kAuto;
};

class GpuStamper {
 public:
  // kAuto's limit (a 362x362 rect). On llvmpipe the vertex stage runs single-threaded at about
  // the CPU reference's speed whatever the other cores are doing; a compute dispatch pays a
  // hand-off to the worker threads and gains only where they find idle cores. Measured on the
  // 2-core machine of bench/results/gpu-stamps.md: at 10^4 samples 0.09 ms vertex against
  // 0.12-0.19 ms compute; at 6.5-9x10^4 samples, with other builds running, compute took
  // 1.1-1.5x the CPU time and the vertex stage 1.04x; at 1.6x10^5 compute took 0.77 ms at
  // best against 1.2-1.3 ms for the vertex stage.
  static constexpr int64_t kVertexPathMaxSamples = 128 * 1024;

  // Uploads both layers of `world`. `textures` (may be null) must outlive the stamper.
  // Errors: a layer larger than GL_MAX_TEXTURE_SIZE, a shader that does not build,
  // StampPath::kVertex without vertex-stage image stores and storage buffers.
  static Result<std::unique_ptr<GpuStamper>> create(const World& world,
                                                    const TextureRegistry* textures = nullptr,
                                                    const StampLimits& limits = {},
                                                    const GpuStamperOptions& options = {});
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

  // The stage that runs a per-sample stamp whose rect has `samples` samples.
  StampPath path_for(int64_t samples) const;

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
  Status build_programs();
  Status stamp_per_sample(const QuantizedStamp& q, RectI& readback);
  void bind_vertex_pass(Layer layer, const RectI& rect);
  void draw_points(GLuint program, GLsizei points);
  Status stamp_shockwave(const QuantizedStamp& q, RectI& readback);
  void reset_contact();
  void queue_readback(Layer layer, const RectI& rect);
  Status texture_for(uint64_t id, GLuint& out);

  const TextureRegistry* textures_ = nullptr;
  StampLimits limits_;
  GpuStamperOptions options_;
  bool software_ = false;     // GL_RENDERER is a CPU rasterizer
  bool vertex_path_ = false;  // the vertex stage has what the vertex pass needs
  WorldParams params_;
  RectI coarse_rect_, detail_rect_;
  GlTexture coarse_, detail_;
  GlBuffer params_buf_, result_buf_, wave_a_, wave_b_;
  size_t wave_capacity_ = 0;
  // Vertex path: the copy of the rect it reads (one per layer format, grown on demand), and
  // an empty framebuffer and vertex array to draw with.
  GlTexture old_coarse_, old_detail_;
  int64_t old_coarse_w_ = 0, old_coarse_h_ = 0, old_detail_w_ = 0, old_detail_h_ = 0;
  GlFramebuffer empty_fbo_;
  GlVertexArray empty_vao_;
  std::map<std::string, GlProgram> programs_;
  std::unordered_map<uint64_t, GlTexture> stamp_textures_;
  std::deque<Pending> pending_;
  std::vector<Pending> free_pbos_;
  uint64_t next_ticket_ = 1;
};

}  // namespace loam::gpu
