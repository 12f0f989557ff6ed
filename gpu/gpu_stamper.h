// The GPU stamp backend's engine: a GPU tile cache of a World's mip-0 layers, stamped in
// shaders that reproduce the CPU reference (protocol/stamps/) bit for bit, with the changed
// samples read back asynchronously into the World (the CPU mirror).
//
// Resources: per layer a TilePages (tile_pages.h): 256x256 pages in a 2D array texture
// (R16UI coarse, R8I detail) and the page table, bounded by GpuStamperOptions whatever the
// world's size; mips, hashes and versions stay with World::commit on the mirror. Nothing is
// uploaded at creation: a stamp first makes the tiles under its rect resident (a tile not
// resident is uploaded from the mirror, which is then current for it; the least recently used
// page not awaiting a readback is reused), then runs once per tile it touches with that
// page bound as a 2D image. A stamp bakes its per-stamp constants on the CPU (bake_stamp,
// the same code as the reference) into a uniform block, then runs the per-sample kernel
// (shaders/stamp_common.glsl) over the stamp's rect only and updates the texels in place
// with image stores; texture stamps are read with texelFetch and integer weights.
// Shockwaves ping-pong a wave field in two storage buffers and apply it page by page.
//
// Where the kernel runs (StampPath): a compute shader, or, for small stamps on a software
// renderer, a vertex shader drawing points that are clipped away. llvmpipe hands every
// compute dispatch to its worker threads and waits for them; on a machine whose idle cores
// take tens of microseconds to wake, that hand-off alone costs more than a whole small stamp
// on the CPU, while the vertex stage runs on the calling thread. The vertex pass reads the
// old samples from a copy of the rect (a vertex may be shaded twice; the pass must be
// idempotent). Both passes share the kernel, and both are checked against the reference.
//
// Readback: without GpuStamperOptions::read_back (a viewer's display, whose mirror copies the
// confirmed store) nothing is read back: submit() stamps and returns. Otherwise submit() queues a read of the
// stamp's rect into a pixel buffer object plus a fence and returns at once; collect() waits for the fences in
// order, maps each buffer, compares it with the mirror (which holds the state before that stamp; per-sample
// atomics in the shader would serialize on llvmpipe) and writes the samples that differ straight into the
// World's tiles, marking exactly the changed rect of each tile dirty. The World is only ever written by
// collect(), on the caller's thread, after the transfer into the buffer has completed, so the mirror is never
// read or written while a transfer is in flight; between submit() and collect() the mirror is simply older
// than the GPU copy. apply() is submit + collect: the reference's contract.
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
#include "gpu/stamp_program.h"
#include "gpu/stamp_results.h"
#include "gpu/tile_pages.h"
#include "gpu/uniform_block.h"
#include "protocol/geometry.h"
#include "protocol/layer.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {
class World;
}

namespace loam::gpu {

// Which shader stage runs the per-sample kinds (shockwaves always run in compute).
enum class StampPath {
  kAuto,     // the vertex stage for rects of at most kVertexPathMaxSamples on a software
             // renderer that has vertex image stores; compute otherwise
  kCompute,  // always compute
  kVertex,   // always the vertex stage (tests); create() fails where it is unavailable
};

struct GpuStamperOptions {
  StampPath path = StampPath::kAuto;
  // Page budgets per layer (pages of 256x256 samples): 1024 coarse pages are 128 MiB, 1024
  // detail pages 64 MiB. A stamp reaching more tiles of a layer than its budget is refused
  // (kOversize).
  PerLayer<int32_t> max_pages{{1024, 1024}};
  // false: nothing is read back. The caller keeps the mirror current itself (a display that
  // copies the confirmed store): submit() stamps the GPU copy alone and holds the pages it
  // stamped until end_batch(), once the mirror holds what they hold (a page is only ever
  // refilled from a mirror that is current for it); collect() returns nothing.
  bool read_back = true;
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

  // A stamper for `world` (its mirror, which must outlive it and be the World given to
  // collect() and upload()). `textures` (may be null) must outlive the stamper.
  // Errors: a page budget beyond GL_MAX_ARRAY_TEXTURE_LAYERS, a shader that does not build,
  // StampPath::kVertex without vertex-stage image stores and storage buffers.
  static Result<std::unique_ptr<GpuStamper>> create(const World& world,
                                                    const TextureRegistry* textures = nullptr,
                                                    const StampLimits& limits = {},
                                                    const GpuStamperOptions& options = {});
  ~GpuStamper();
  GpuStamper(const GpuStamper&) = delete;
  GpuStamper& operator=(const GpuStamper&) = delete;

  // Validates q (check_quantized), stamps the GPU copy and queues the readback of its rect.
  // Returns a ticket (increasing). On error nothing was changed. kBusy: the tiles it needs
  // cannot be made resident until readbacks are collected (collect and submit again);
  // kOversize: it reaches more tiles than the page budget.
  Result<uint64_t> submit(const QuantizedStamp& q);
  // Waits for every queued readback, oldest first, and writes the changed samples into
  // `world` (marking them dirty; the caller commits). Returns one entry per ticket.
  std::vector<StampReadback> collect(World& world);
  size_t pending() const { return pending_.size(); }
  // Without read_back: the mirror now holds every stamp submitted, their pages may be evicted.
  void end_batch();

  // The CPU reference's contract (apply_stamp): apply q to the GPU copy and the mirror,
  // return the bounding rect of the samples that changed (empty: none).
  Result<RectI> apply(World& world, const QuantizedStamp& q);

  // Re-uploads a rect of a layer from the mirror, after the World changed outside the
  // stamper (a region from the server, a snapshot). Collects first. Only resident tiles are
  // touched: the others are uploaded when next needed.
  void upload(World& world, Layer layer, const RectI& rect);
  // The tile (layer tile grid) leaves the cache (its samples are no longer wanted). Collects
  // first.
  void forget(World& world, Layer layer, int32_t tx, int32_t ty);

  // Reads a rect of the GPU copy synchronously, making its tiles resident (tests and
  // benchmarks; stalls the pipeline). Empty where the tiles cannot be made resident.
  std::vector<int32_t> read_gpu(Layer layer, const RectI& rect);
  // Copies a rect of a layer (global samples, inside the layer) into texel (dst_x, dst_y) of
  // a 2D texture of the layer's format, GPU to GPU, making its tiles resident. False where
  // they cannot be made resident (collect first).
  bool copy_to(Layer layer, const RectI& rect, GLuint dst_texture, int32_t dst_x, int32_t dst_y);

  RectI layer_rect(Layer layer) const { return layers_[layer].rect; }
  const TilePages& pages(Layer layer) const { return layers_[layer].pages; }
  GpuStamperMemory memory() const;
  const GpuStamperTraffic& traffic() const { return traffic_; }

  // The stage that runs a per-sample stamp whose rect has `samples` samples.
  StampPath path_for(int64_t samples) const;

 private:
  // What the stamper holds for one layer: its page cache, its samples (global rect), and the
  // vertex path's copy of the rect a pass reads (in the layer's format, grown on demand).
  struct GpuLayer {
    TilePages pages;
    RectI rect;
    GlTexture old;
    int64_t old_w = 0, old_h = 0;
  };
  explicit GpuStamper(PerLayer<GpuLayer> layers) : layers_(std::move(layers)) {}
  // The part of a rect inside one resident tile.
  struct PagePart {
    int32_t page = 0;
    RectI tile;  // the tile's global samples
    RectI rect;  // global samples, inside `tile`
  };
  struct Pending {
    uint64_t ticket = 0;
    Layer layer = Layer::kCoarse;
    RectI rect;  // read back, global layer samples
    size_t pixel_bytes = 0;
    GlBuffer pbo;
    size_t capacity = 0;
    GlSync fence;
    std::vector<int32_t> pinned;  // pages of `layer` kept until the readback is collected
  };
  TilePages& pages_mut(Layer layer) { return layers_[layer].pages; }
  // Where a stamp's constants go: the slot of the parameter buffer holding its profile table
  // (fresh: the table must be written with the first part's header).
  struct TableSlot {
    size_t offset = 0;
    bool fresh = false;
  };
  TableSlot table_slot(const ProfileTable& table);
  // Makes every tile under `rect` resident (filling fresh pages from the mirror) and pins
  // their pages; the caller unpins them (release) or hands them to a readback.
  Result<std::vector<PagePart>> resident_parts(Layer layer, const RectI& rect);
  void release(Layer layer, const std::vector<PagePart>& parts);
  void fill_page(Layer layer, int32_t page, int32_t tx, int32_t ty);
  Result<GLuint> program(const ProgramKey& key);
  Status build_programs();
  Status stamp_per_sample(const QuantizedStamp& q, const BakedStamp& b, const std::vector<PagePart>& parts);
  void bind_vertex_pass(Layer layer, const PagePart& part);
  void draw_points(GLuint program, GLsizei points);
  Status stamp_shockwave(const QuantizedStamp& q, const BakedStamp& b, const RectI& box,
                         const std::vector<PagePart>& parts);
  // The rect a baked stamp may change (inside the layer; empty: none).
  RectI stamp_rect(const QuantizedStamp& q, const BakedStamp& b) const;
  void reset_contact();
  void queue_readback(Layer layer, const RectI& rect, const std::vector<PagePart>& parts);
  Status texture_for(uint64_t id, GLuint& out);

  const TextureRegistry* textures_ = nullptr;
  StampLimits limits_;
  GpuStamperOptions options_;
  bool software_ = false;     // GL_RENDERER is a CPU rasterizer
  bool vertex_path_ = false;  // the vertex stage has what the vertex pass needs
  const World* mirror_ = nullptr;
  WorldParams params_;
  PerLayer<GpuLayer> layers_;
  GlBuffer params_buf_, result_buf_, wave_a_, wave_b_;
  // The parameter buffer's slots (StampParams blocks), each keeping the last profile table
  // written to it; least recently used is rewritten.
  static constexpr size_t kTableSlots = 32;
  struct Slot {
    ProfileTable table{};
    uint64_t used = 0;  // 0: never written
  };
  std::vector<Slot> slots_;
  size_t slot_stride_ = 0;
  uint64_t table_clock_ = 0;
  UniformBuffer<WaveBlock> wave_block_;
  size_t wave_capacity_ = 0;
  // Vertex path: an empty framebuffer and vertex array to draw with.
  GlFramebuffer empty_fbo_;
  GlVertexArray empty_vao_;
  std::map<ProgramKey, GlProgram> programs_;
  std::unordered_map<uint64_t, GlTexture> stamp_textures_;
  std::deque<Pending> pending_;
  std::vector<Pending> free_pbos_;
  std::vector<std::pair<Layer, int32_t>> held_;  // pages stamped without read_back, until end_batch()
  GpuStamperTraffic traffic_;
  uint64_t next_ticket_ = 1;
};

}  // namespace loam::gpu
