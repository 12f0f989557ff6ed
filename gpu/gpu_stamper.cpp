#include "gpu/gpu_stamper.h"

#include <algorithm>
#include <cctype>
#include <climits>
#include <cstring>
#include <tuple>
#include <utility>

#include "gpu/egl_context.h"
#include "gpu/gl_debug.h"
#include "gpu/shader_library.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_kinds.h"
#include "protocol/world.h"

namespace loam::gpu {

namespace {

// Mirrors the StampParams uniform block in shaders/stamp_common.glsl: std140 of five ivec4
// and ivec4 table4[257] is exactly these consecutive int32 (the table padded to 1028).
struct StampUniforms {
  int32_t rect_x0, rect_y0, rect_w, rect_h;
  int32_t d0x, d0y, shift, radius_r;
  int32_t cos_q15, sin_q15, intensity, target;
  int32_t blend, tex_w, tex_h, vertex_runs_per_row;
  int32_t wave_stride, wave_origin_x, wave_origin_y, pad0;
  int32_t table[kProfileEntries + 4];
};
static_assert(sizeof(StampUniforms) == (20 + kProfileEntries + 4) * 4);
// The per-part fields before the table: all a part rewrites where its table is already there.
constexpr size_t kStampHeaderBytes = offsetof(StampUniforms, table);
static_assert(kStampHeaderBytes == 80);

constexpr GLuint kWaveBinding = 4;
const UniformBlockMember kWaveMembers[] = {
    LOAM_UNIFORM_MEMBER(WaveBlock, active_rect, "active_rect"),
    LOAM_UNIFORM_MEMBER(WaveBlock, texel_origin, "texel_origin"),
    LOAM_UNIFORM_MEMBER(WaveBlock, stride, "stride"),
    LOAM_UNIFORM_MEMBER(WaveBlock, nu2_q16, "nu2_q16"),
    LOAM_UNIFORM_MEMBER(WaveBlock, damping_q16, "damping_q16"),
    {"w_pad0", offsetof(WaveBlock, pad) + 0},
    {"w_pad1", offsetof(WaveBlock, pad) + 4},
    {"w_pad2", offsetof(WaveBlock, pad) + 8},
};
void set_rect(int32_t (&out)[4], const RectI& r) {
  out[0] = int32_t(r.x0), out[1] = int32_t(r.y0), out[2] = int32_t(r.x1), out[3] = int32_t(r.y1);
}

// Mirrors StampResult: the footprint's first point of contact; INT_MIN (kNoContact in the
// shaders) when no sample lies under the foot.
constexpr int32_t kNoContact = INT_MIN;

constexpr GLuint kGroup = 8;     // local_size_x/y of every compute stamp shader
constexpr int kComputeRows = 4;  // samples per compute invocation (STAMP_ROWS), along y
constexpr int kVertexRun = 4;    // samples per vertex-pass point (STAMP_RUN), along x

GLuint groups(int64_t n, int64_t per_group = kGroup) { return GLuint((n + per_group - 1) / per_group); }

GLenum pixel_type(Layer l) { return GLenum(layer_info(l).gl_type); }
size_t pixel_size(Layer l) { return size_t(layer_info(l).bytes_per_sample); }

// First and last index in [0, n) where a and b differ ({-1, -1}: none). b == nullptr: an
// implicit zero tile.
template <typename T>
std::pair<int64_t, int64_t> differing_span(const T* a, const T* b, int64_t n) {
  int64_t first = 0, last = n - 1;
  if (b != nullptr) {
    if (std::memcmp(a, b, size_t(n) * sizeof(T)) == 0) return {-1, -1};
    while (a[first] == b[first]) ++first;
    while (a[last] == b[last]) --last;
  } else {
    while (first < n && a[first] == 0) ++first;
    if (first == n) return {-1, -1};
    while (a[last] == 0) --last;
  }
  return {first, last};
}

// Writes a readback of `rect` (row-major, layer samples) into the world where it differs
// from it, tile by tile: each row's differing span is copied, each tile's changed rect
// marked dirty (as write_coarse / write_detail and the reference's tile walk mark it).
// Returns the bounding rect of the changed samples (global; empty: none). An absent detail
// tile is all zero and is only stored when something in it changes.
template <typename T>
RectI write_readback(World& world, Layer layer, const RectI& rect, const T* data) {
  RectI changed;
  const RectI tiles = tiles_overlapping(rect);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      const RectI part = rect.intersect(tile_rect(int32_t(tx), int32_t(ty)));
      if (part.empty()) continue;
      T* tile = nullptr;
      const T* current = nullptr;
      if constexpr (sizeof(T) == 2) {
        tile = world.coarse_tile_mut(int32_t(tx), int32_t(ty)).data();
        current = tile;
      } else {
        const std::span<const int8_t> stored = world.detail_tile(int32_t(tx), int32_t(ty));
        if (!stored.empty()) tile = world.detail_tile_mut(int32_t(tx), int32_t(ty)).data();
        current = tile;
      }
      RectI dirty;
      for (int64_t y = part.y0; y < part.y1; ++y) {
        const T* src = data + (y - rect.y0) * rect.width() + (part.x0 - rect.x0);
        const int64_t at = (y - ty * kTileSize) * kTileSize + (part.x0 - tx * kTileSize);
        const auto [first, last] = differing_span(src, current ? current + at : nullptr, part.width());
        if (first < 0) continue;
        if (tile == nullptr) {
          if constexpr (sizeof(T) == 1) tile = world.detail_tile_mut(int32_t(tx), int32_t(ty)).data();
          current = tile;
        }
        std::memcpy(tile + at + first, src + first, size_t(last - first + 1) * sizeof(T));
        dirty = dirty.unite(RectI{part.x0 + first, y, part.x0 + last + 1, y + 1});
      }
      if (!dirty.empty()) {
        world.mark_dirty(layer, dirty);
        changed = changed.unite(dirty);
      }
    }
  }
  return changed;
}

// Saves and restores what a vertex-path draw changes of the caller's GL state.
class DrawStateGuard {
 public:
  DrawStateGuard() {
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &framebuffer_);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &vertex_array_);
    discard_ = glIsEnabled(GL_RASTERIZER_DISCARD);
    if (discard_) glDisable(GL_RASTERIZER_DISCARD);  // it would skip the vertex stage too
  }
  ~DrawStateGuard() {
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, GLuint(framebuffer_));
    glBindVertexArray(GLuint(vertex_array_));
    if (discard_) glEnable(GL_RASTERIZER_DISCARD);
  }
  DrawStateGuard(const DrawStateGuard&) = delete;
  DrawStateGuard& operator=(const DrawStateGuard&) = delete;

 private:
  GLint framebuffer_ = 0, vertex_array_ = 0;
  GLboolean discard_ = GL_FALSE;
};

}  // namespace

GpuStamper::~GpuStamper() = default;

Result<std::unique_ptr<GpuStamper>> GpuStamper::create(const World& world, const TextureRegistry* textures,
                                                       const StampLimits& limits,
                                                       const GpuStamperOptions& options) {
  install_gl_debug_output();
  std::vector<GpuLayer> made;
  for (const Layer l : kLayers) {
    auto pages = TilePages::create(l, options.max_pages[l]);
    if (!pages) return pages.error();
    made.push_back({std::move(*pages), layer_sample_rect(world.params(), l), {}, 0, 0});
  }
  static_assert(kLayerCount == 2, "one GpuLayer per row of the layer table");
  std::unique_ptr<GpuStamper> s(new GpuStamper(PerLayer<GpuLayer>{{std::move(made[0]), std::move(made[1])}}));
  s->mirror_ = &world;
  s->textures_ = textures;
  s->limits_ = limits;
  s->options_ = options;
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  s->software_ = renderer != nullptr && is_software_renderer(renderer);
  // The vertex pass needs two images (the layer and the copy it reads), the texture sampler
  // and the footprint's storage buffer in the vertex stage.
  GLint images = 0, buffers = 0;
  glGetIntegerv(GL_MAX_VERTEX_IMAGE_UNIFORMS, &images);
  glGetIntegerv(GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS, &buffers);
  s->vertex_path_ = images >= 2 && buffers >= 1;
  if (options.path == StampPath::kVertex && !s->vertex_path_) {
    return make_error(ErrorCode::kUnsupported, "gpu.stamp_path",
                      "the vertex stage offers " + std::to_string(images) + " image units and " +
                          std::to_string(buffers) + " storage buffers; the vertex pass needs 2 and 1");
  }
  s->params_ = world.params();
  if (Status st = s->build_programs(); !st.ok()) return st.error();

  // One slot per profile table kept: a stamp whose table is there uploads its 80-byte header.
  s->slot_stride_ = (sizeof(StampUniforms) + uniform_buffer_alignment() - 1) / uniform_buffer_alignment() *
                    uniform_buffer_alignment();
  s->params_buf_ = make_buffer();
  glNamedBufferStorage(s->params_buf_.get(), GLsizeiptr(s->slot_stride_ * kTableSlots), nullptr,
                       GL_DYNAMIC_STORAGE_BIT);
  s->slots_.resize(kTableSlots);
  s->result_buf_ = make_buffer();
  glNamedBufferStorage(s->result_buf_.get(), sizeof kNoContact, &kNoContact, GL_DYNAMIC_STORAGE_BIT);
  if (s->vertex_path_ && options.path != StampPath::kCompute) {
    GLuint fbo = 0, vao = 0;
    glCreateFramebuffers(1, &fbo);
    s->empty_fbo_ = GlFramebuffer(fbo);
    // No attachments: every point is clipped anyway, but a draw needs a complete framebuffer
    // (a surfaceless context has no default one).
    glNamedFramebufferParameteri(fbo, GL_FRAMEBUFFER_DEFAULT_WIDTH, 1);
    glNamedFramebufferParameteri(fbo, GL_FRAMEBUFFER_DEFAULT_HEIGHT, 1);
    glCreateVertexArrays(1, &vao);
    s->empty_vao_ = GlVertexArray(vao);
  }
  return s;
}

StampPath GpuStamper::path_for(int64_t samples) const {
  switch (options_.path) {
    case StampPath::kCompute: return StampPath::kCompute;
    case StampPath::kVertex: return StampPath::kVertex;
    case StampPath::kAuto: break;
  }
  return software_ && vertex_path_ && samples <= kVertexPathMaxSamples ? StampPath::kVertex
                                                                       : StampPath::kCompute;
}

namespace {

// Each pass: its define and the shader file of each stage (null: no such stage). The stamp
// passes share stamp_common.glsl with their stage's file; the wave step and apply stand alone.
struct PassRow {
  const char* define;
  const char* compute_file;
  const char* vertex_file;
  bool with_common;
};
constexpr PerStampPass<PassRow> kPasses{{{
    {"PASS_STAMP", "stamp.comp.glsl", "stamp.vert.glsl", true},
    {"PASS_CONTACT", "stamp.comp.glsl", "stamp.vert.glsl", true},
    {"PASS_WAVE_INIT", "stamp.comp.glsl", nullptr, true},
    {"PASS_STEP", "shockwave.comp.glsl", nullptr, false},
    {"PASS_APPLY", "shockwave.comp.glsl", nullptr, false},
}}};

// The kinds table as the shaders' constants.
std::vector<ShaderDefine> kind_defines(StampKind kind) {
  std::vector<ShaderDefine> d = {{"KIND", std::to_string(int(kind))},
                                 {"KIND_NEEDS_CONTACT", stamp_kind(kind).needs_contact ? "1" : "0"}};
  for (const StampKindRow& r : kStampKinds)
    d.push_back({"KIND_" + std::string(r.constant), std::to_string(int(r.kind))});
  return d;
}

}  // namespace

Result<GLuint> GpuStamper::program(const ProgramKey& key) {
  const auto found = programs_.find(key);
  if (found != programs_.end()) return found->second.get();
  const PassRow& pass = kPasses[key.pass];
  const bool vertex = key.stage == ShaderStage::kVertex;
  const char* file = vertex ? pass.vertex_file : pass.compute_file;
  if (file == nullptr)
    return make_error(ErrorCode::kInvalidArgument, "program", "the pass has no such stage");
  std::vector<ShaderDefine> defines = kind_defines(key.kind);
  // LAYER_<NAME>: the shaders' sample type and range.
  std::string layer_define = "LAYER_";
  for (const char* n = layer_info(key.layer).name; *n != 0; ++n)
    layer_define += char(std::toupper(uint8_t(*n)));
  defines.push_back({layer_define, "1"});
  defines.push_back({pass.define, "1"});
  defines.push_back({"STAMP_ROWS", std::to_string(kComputeRows)});
  defines.push_back({"STAMP_RUN", std::to_string(kVertexRun)});
  Result<GlProgram> built = [&] {
    const std::string_view files[] = {"stamp_common.glsl", file};
    if (!pass.with_common) return build_compute_program(file, defines);
    if (vertex) return build_vertex_program_from(files, defines);
    return build_compute_program_from(files, defines);
  }();
  if (!built) return built.error();
  if (!pass.with_common) {
    // The wave step and apply read their parameters from the checked block alone.
    LOAM_TRY(verify_uniform_block(built->get(), "WaveParams", sizeof(WaveBlock), kWaveMembers));
    LOAM_TRY(verify_no_loose_uniforms(built->get()));
  }
  const GLuint name = built->get();
  programs_.emplace(key, std::move(*built));
  return name;
}

// Every program a per-sample stamp may use, up front: a shader error shows at start-up, not
// at the first stamp.
Status GpuStamper::build_programs() {
  const bool compute = options_.path != StampPath::kVertex;
  const bool vertex = vertex_path_ && options_.path != StampPath::kCompute && (software_ || !compute);
  for (const Layer l : kLayers) {
    for (const StampKindRow& k : kStampKinds) {
      if (!k.per_sample) continue;
      for (const auto& [use, pass, stage] :
           {std::tuple{compute, StampPass::kStamp, ShaderStage::kCompute},
            std::tuple{compute && k.needs_contact, StampPass::kContact, ShaderStage::kCompute},
            std::tuple{vertex, StampPass::kStamp, ShaderStage::kVertex},
            std::tuple{vertex && k.needs_contact, StampPass::kContact, ShaderStage::kVertex}}) {
        if (!use) continue;
        auto p = program({pass, k.kind, l, stage});
        if (!p) return p.error();
      }
    }
  }
  return {};
}

void GpuStamper::reset_contact() {
  glNamedBufferSubData(result_buf_.get(), 0, sizeof kNoContact, &kNoContact);
  traffic_.bytes_uploaded += sizeof kNoContact;
}

Status GpuStamper::texture_for(uint64_t id, GLuint& out) {
  const auto found = stamp_textures_.find(id);
  if (found != stamp_textures_.end()) {
    out = found->second.get();
    return {};
  }
  const StampTexture* t = textures_ ? textures_->find(id) : nullptr;
  if (!t) return make_error(ErrorCode::kNotFound, "stamp.texture_id", "no registered texture has this id");
  GlTexture tex = make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(tex.get(), 1, GL_R16UI, t->width, t->height);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(tex.get(), 0, 0, 0, t->width, t->height, GL_RED_INTEGER, GL_UNSIGNED_SHORT,
                      t->samples.data());
  // Integer textures are never filtered; texelFetch ignores samplers anyway.
  glTextureParameteri(tex.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(tex.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  out = tex.get();
  stamp_textures_.emplace(id, std::move(tex));
  return {};
}

void GpuStamper::fill_page(Layer layer, int32_t page, int32_t tx, int32_t ty) {
  const PageFormat f = page_format(layer);
  const GLuint tex = pages(layer).texture();
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  visit_layer(layer, [&](auto row) {
    using R = decltype(row);
    const auto tile = mirror_->tile_samples<R>(TileCoord{R::kLayer, 0, tx, ty});
    ++traffic_.page_fills;
    if (tile.empty()) {
      const typename R::Sample zero{};  // an unstored tile (detail) is all zero
      glClearTexSubImage(tex, 0, 0, 0, page, kTileSize, kTileSize, 1, f.format, f.type, &zero);
      traffic_.bytes_uploaded += sizeof zero;
    } else {
      glTextureSubImage3D(tex, 0, 0, 0, page, kTileSize, kTileSize, 1, f.format, f.type, tile.data());
      traffic_.bytes_uploaded += tile.size_bytes();
    }
  });
}

Result<std::vector<GpuStamper::PagePart>> GpuStamper::resident_parts(Layer layer, const RectI& rect) {
  std::vector<PagePart> parts;
  const RectI r = rect.intersect(layer_rect(layer));
  if (r.empty()) return parts;
  TilePages& p = pages_mut(layer);
  const RectI tiles = tiles_overlapping(r);
  if (tiles.area() > p.max_pages()) {
    return make_error(ErrorCode::kOversize, "gpu.pages",
                      "a stamp over " + std::to_string(tiles.area()) + " " + to_string(layer) +
                          " tiles; the GPU page budget is " + std::to_string(p.max_pages()));
  }
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      const auto slot = p.acquire(int32_t(tx), int32_t(ty));
      if (!slot) {
        release(layer, parts);
        return make_error(ErrorCode::kBusy, "gpu.pages",
                          "every page is awaiting a readback or held by this batch: collect or end the "
                          "batch, then submit again");
      }
      // Pinned at once: a later acquire of this call must not take it back.
      p.pin(slot->page);
      if (slot->fresh) fill_page(layer, slot->page, int32_t(tx), int32_t(ty));
      const RectI tile = tile_rect(int32_t(tx), int32_t(ty));
      parts.push_back({slot->page, tile, r.intersect(tile)});
    }
  }
  return parts;
}

GpuStamper::TableSlot GpuStamper::table_slot(const ProfileTable& table) {
  ++table_clock_;
  // Tables repeat: a kind at the same intensity and shape bakes the same one whatever the
  // radius (a walker's footprints, a tool preset).
  size_t victim = 0;
  for (size_t i = 0; i < slots_.size(); ++i) {
    Slot& s = slots_[i];
    if (s.used != 0 && s.table == table) {
      s.used = table_clock_;
      return {i * slot_stride_, false};
    }
    if (s.used < slots_[victim].used) victim = i;
  }
  slots_[victim].table = table;
  slots_[victim].used = table_clock_;
  return {victim * slot_stride_, true};
}

void GpuStamper::release(Layer layer, const std::vector<PagePart>& parts) {
  for (const PagePart& part : parts) pages_mut(layer).unpin(part.page);
}

RectI GpuStamper::stamp_rect(const QuantizedStamp& q, const BakedStamp& b) const {
  const RectI layer = layer_rect(q.layer);
  if (q.kind != StampKind::kShockwave) return b.rect.intersect(layer);
  const int64_t total = int64_t(q.steps) * shockwave_substeps(q.speed);
  const RectI pulse{ceil_div(q.center_x - b.support_q8, 256), ceil_div(q.center_y - b.support_q8, 256),
                    floor_div(q.center_x + b.support_q8, 256) + 1,
                    floor_div(q.center_y + b.support_q8, 256) + 1};
  return RectI{pulse.x0 - total, pulse.y0 - total, pulse.x1 + total, pulse.y1 + total}.intersect(layer);
}

Status GpuStamper::stamp_per_sample(const QuantizedStamp& q, const BakedStamp& b,
                                    const std::vector<PagePart>& parts) {
  if (parts.empty()) return {};
  const bool vertex = path_for(b.rect.area()) == StampPath::kVertex;
  StampUniforms u{};
  u.shift = b.shift;
  u.radius_r = b.radius_r;
  u.cos_q15 = b.cos_q15;
  u.sin_q15 = b.sin_q15;
  u.intensity = q.intensity;
  u.target = q.target;
  u.blend = int32_t(q.blend);
  if (b.texture) {
    u.tex_w = b.texture->width;
    u.tex_h = b.texture->height;
    GLuint tex = 0;
    if (Status st = texture_for(q.texture_id, tex); !st.ok()) return st;
    glBindTextureUnit(0, tex);
  }
  std::copy(b.table.begin(), b.table.end(), u.table);
  const TableSlot slot = table_slot(b.table);
  const bool whole = slot.fresh;  // the first part writes the table too
  bool header = false;
  // The per-part fields: where the part lies in its page and relative to the center.
  auto load_part = [&](const PagePart& part) {
    u.rect_x0 = int32_t(part.rect.x0 - part.tile.x0);
    u.rect_y0 = int32_t(part.rect.y0 - part.tile.y0);
    u.rect_w = int32_t(part.rect.width());
    u.rect_h = int32_t(part.rect.height());
    // gx * 256 - center_x = (gx - rect.x0) * 256 + d0x; |d0x| <= support < 2^25.
    u.d0x = int32_t(part.rect.x0 * 256 - q.center_x);
    u.d0y = int32_t(part.rect.y0 * 256 - q.center_y);
    u.vertex_runs_per_row = int32_t((part.rect.width() + kVertexRun - 1) / kVertexRun);
    if (!header) {
      // The first part writes the stamp's header (and its table where the slot lacks it).
      const size_t bytes = whole ? sizeof u : kStampHeaderBytes;
      glNamedBufferSubData(params_buf_.get(), GLintptr(slot.offset), GLsizeiptr(bytes), &u);
      traffic_.bytes_uploaded += bytes;
      header = true;
    } else {
      // The next ones only what is the part's own: its rect, its offset from the centre and
      // the vertex pass's runs (28 bytes).
      const auto put = [&](size_t offset, size_t bytes) {
        glNamedBufferSubData(params_buf_.get(), GLintptr(slot.offset + offset), GLsizeiptr(bytes),
                             reinterpret_cast<const char*>(&u) + offset);
        traffic_.bytes_uploaded += bytes;
      };
      put(offsetof(StampUniforms, rect_x0), 4 * sizeof(int32_t));
      put(offsetof(StampUniforms, d0x), 2 * sizeof(int32_t));
      put(offsetof(StampUniforms, vertex_runs_per_row), sizeof(int32_t));
    }
    glBindBufferRange(GL_UNIFORM_BUFFER, 0, params_buf_.get(), GLintptr(slot.offset), sizeof u);
  };
  const bool contact_pass = stamp_kind(q.kind).needs_contact;
  if (contact_pass) {
    // First contact: max over the whole foot (every part) of old - sole, gathered by a
    // pre-pass, then read by the stamp passes from the same buffer (no round trip to the CPU).
    reset_contact();
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, result_buf_.get());
  }
  const GLuint pages_tex = pages(q.layer).texture();
  const GLenum format = page_format(q.layer).internal_format;
  if (vertex) {
    auto prog = program({StampPass::kStamp, q.kind, q.layer, ShaderStage::kVertex});
    if (!prog) return prog.error();
    auto points = [](const PagePart& part) {
      return GLsizei(((part.rect.width() + kVertexRun - 1) / kVertexRun) * part.rect.height());
    };
    if (contact_pass) {
      auto contact = program({StampPass::kContact, q.kind, q.layer, ShaderStage::kVertex});
      if (!contact) return contact.error();
      for (const PagePart& part : parts) {
        load_part(part);
        bind_vertex_pass(q.layer, part);
        draw_points(*contact, points(part));
      }
      glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    }
    for (const PagePart& part : parts) {
      load_part(part);
      bind_vertex_pass(q.layer, part);
      draw_points(*prog, points(part));
    }
    return {};
  }
  auto dispatch = [&](GLuint prog, const PagePart& part) {
    load_part(part);
    // One layer of the page array, bound as the 2D image the kernel stores into.
    glBindImageTexture(0, pages_tex, 0, GL_FALSE, part.page, GL_READ_WRITE, format);
    glUseProgram(prog);
    glDispatchCompute(groups(part.rect.width()), groups(part.rect.height(), kGroup * kComputeRows), 1);
  };
  if (contact_pass) {
    auto contact = program({StampPass::kContact, q.kind, q.layer, ShaderStage::kCompute});
    if (!contact) return contact.error();
    for (const PagePart& part : parts) dispatch(*contact, part);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  }
  auto prog = program({StampPass::kStamp, q.kind, q.layer, ShaderStage::kCompute});
  if (!prog) return prog.error();
  for (const PagePart& part : parts) dispatch(*prog, part);
  return {};
}

// Before a vertex pass over a part: copies the part into the texture the pass reads the old
// samples from (part-local texels) and binds both images (the page as a 2D image).
void GpuStamper::bind_vertex_pass(Layer layer, const PagePart& part) {
  GpuLayer& g = layers_[layer];
  GlTexture& old = g.old;
  int64_t& old_w = g.old_w;
  int64_t& old_h = g.old_h;
  const GLenum format = page_format(layer).internal_format;
  if (part.rect.width() > old_w || part.rect.height() > old_h) {
    old_w = std::max(old_w, part.rect.width());
    old_h = std::max(old_h, part.rect.height());
    old = make_texture(GL_TEXTURE_2D);
    glTextureStorage2D(old.get(), 1, format, GLsizei(old_w), GLsizei(old_h));
  }
  const GLuint tex = pages(layer).texture();
  // Image stores of earlier passes must land before the copy reads the page, and the copy
  // before this pass reads it.
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  glCopyImageSubData(tex, GL_TEXTURE_2D_ARRAY, 0, GLint(part.rect.x0 - part.tile.x0),
                     GLint(part.rect.y0 - part.tile.y0), part.page, old.get(), GL_TEXTURE_2D, 0, 0, 0, 0,
                     GLsizei(part.rect.width()), GLsizei(part.rect.height()), 1);
  glBindImageTexture(0, tex, 0, GL_FALSE, part.page, GL_WRITE_ONLY, format);
  glBindImageTexture(1, old.get(), 0, GL_FALSE, 0, GL_READ_ONLY, format);
}

// One vertex-stage pass: `points` points, every one clipped away, with the caller's
// framebuffer, vertex array and rasterizer-discard state restored after.
void GpuStamper::draw_points(GLuint program, GLsizei points) {
  glUseProgram(program);
  const DrawStateGuard guard;
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, empty_fbo_.get());
  glBindVertexArray(empty_vao_.get());
  glDrawArrays(GL_POINTS, 0, points);
}

Status GpuStamper::stamp_shockwave(const QuantizedStamp& q, const BakedStamp& b, const RectI& box,
                                   const std::vector<PagePart>& parts) {
  if (box.empty()) return {};
  const int32_t sub = shockwave_substeps(q.speed);
  const int32_t nu2 = shockwave_nu2_q16(q.speed, sub);
  const int64_t total = int64_t(q.steps) * sub;
  const RectI pulse{ceil_div(q.center_x - b.support_q8, 256), ceil_div(q.center_y - b.support_q8, 256),
                    floor_div(q.center_x + b.support_q8, 256) + 1,
                    floor_div(q.center_y + b.support_q8, 256) + 1};
  for (const StampPass pass : {StampPass::kWaveInit, StampPass::kWaveStep, StampPass::kWaveApply}) {
    auto p = program({pass, q.kind, q.layer, ShaderStage::kCompute});
    if (!p) return p.error();
  }
  const int64_t w = box.width(), h = box.height(), stride = w + 2;
  const size_t bytes = size_t(stride * (h + 2)) * 4;
  if (bytes > wave_capacity_) {
    wave_a_ = make_buffer();
    wave_b_ = make_buffer();
    glNamedBufferStorage(wave_a_.get(), GLsizeiptr(bytes), nullptr, GL_DYNAMIC_STORAGE_BIT);
    glNamedBufferStorage(wave_b_.get(), GLsizeiptr(bytes), nullptr, GL_DYNAMIC_STORAGE_BIT);
    wave_capacity_ = bytes;
  }
  const int32_t zero = 0;
  glClearNamedBufferSubData(wave_a_.get(), GL_R32I, 0, GLsizeiptr(bytes), GL_RED_INTEGER, GL_INT, &zero);
  glClearNamedBufferSubData(wave_b_.get(), GL_R32I, 0, GLsizeiptr(bytes), GL_RED_INTEGER, GL_INT, &zero);

  // The pulse at rest, over the part of the pulse inside the box.
  const RectI init = pulse.intersect(box);
  StampUniforms u{};
  u.rect_w = int32_t(init.width());
  u.rect_h = int32_t(init.height());
  u.d0x = int32_t(init.x0 * 256 - q.center_x);
  u.d0y = int32_t(init.y0 * 256 - q.center_y);
  u.shift = b.shift;
  u.radius_r = b.radius_r;
  u.wave_stride = int32_t(stride);
  u.wave_origin_x = int32_t(init.x0 - box.x0);
  u.wave_origin_y = int32_t(init.y0 - box.y0);
  std::copy(b.table.begin(), b.table.end(), u.table);
  const TableSlot slot = table_slot(b.table);
  const size_t written = slot.fresh ? sizeof u : kStampHeaderBytes;
  glNamedBufferSubData(params_buf_.get(), GLintptr(slot.offset), GLsizeiptr(written), &u);
  traffic_.bytes_uploaded += written;
  glBindBufferRange(GL_UNIFORM_BUFFER, 0, params_buf_.get(), GLintptr(slot.offset), sizeof u);
  GLuint cur = wave_a_.get(), prev = wave_b_.get();
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, cur);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, prev);
  glUseProgram(*program({StampPass::kWaveInit, q.kind, q.layer, ShaderStage::kCompute}));
  if (!init.empty()) glDispatchCompute(groups(init.width()), groups(init.height(), kGroup * kComputeRows), 1);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);

  const GLuint step = *program({StampPass::kWaveStep, q.kind, q.layer, ShaderStage::kCompute});
  glUseProgram(step);
  WaveBlock wb{};
  wb.stride = int32_t(stride);
  wb.nu2_q16 = nu2;
  wb.damping_q16 = int32_t(q.damping);
  wave_block_.bind(kWaveBinding);
  const RectI local_pulse = pulse.translated(-box.x0, -box.y0);
  for (int64_t n = 1; n <= total; ++n) {
    const RectI a =
        RectI{local_pulse.x0 - n, local_pulse.y0 - n, local_pulse.x1 + n, local_pulse.y1 + n}.intersect(
            {0, 0, w, h});
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, cur);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, prev);
    if (!a.empty()) {
      set_rect(wb.active_rect, a);
      wave_block_.write(0, wb);
      traffic_.bytes_uploaded += sizeof wb;
      glDispatchCompute(groups(a.width()), groups(a.height()), 1);
      glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    }
    std::swap(cur, prev);  // as wave_step: the field just written becomes current
  }

  // The final field applied page by page: each part's cells (box-local) into its page.
  const GLuint apply = *program({StampPass::kWaveApply, q.kind, q.layer, ShaderStage::kCompute});
  glUseProgram(apply);
  wave_block_.bind(kWaveBinding);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, cur);
  const GLuint pages_tex = pages(q.layer).texture();
  for (const PagePart& part : parts) {
    const RectI cells = part.rect.translated(-box.x0, -box.y0);
    set_rect(wb.active_rect, cells);
    // The page texel of box cell (0, 0) (outside the page for parts not at the box's corner).
    wb.texel_origin[0] = int32_t(box.x0 - part.tile.x0), wb.texel_origin[1] = int32_t(box.y0 - part.tile.y0);
    wave_block_.write(0, wb);
    traffic_.bytes_uploaded += sizeof wb;
    glBindImageTexture(0, pages_tex, 0, GL_FALSE, part.page, GL_READ_WRITE,
                       page_format(q.layer).internal_format);
    glDispatchCompute(groups(cells.width()), groups(cells.height()), 1);
  }
  return {};
}

void GpuStamper::queue_readback(Layer layer, const RectI& rect, const std::vector<PagePart>& parts) {
  Pending p;
  p.ticket = next_ticket_++;
  p.layer = layer;
  p.rect = rect;
  p.pixel_bytes = size_t(rect.area()) * pixel_size(layer);
  traffic_.bytes_read_back += p.pixel_bytes;
  const size_t need = std::max<size_t>(p.pixel_bytes, 1);
  // Reuse a pixel buffer big enough, else make one (sized with headroom to be reused).
  auto it = std::find_if(free_pbos_.begin(), free_pbos_.end(),
                         [&](const Pending& f) { return f.capacity >= need; });
  if (it != free_pbos_.end()) {
    p.pbo = std::move(it->pbo);
    p.capacity = it->capacity;
    free_pbos_.erase(it);
  } else {
    p.pbo = make_buffer();
    p.capacity = std::max<size_t>(need, 4096);
    glNamedBufferStorage(p.pbo.get(), GLsizeiptr(p.capacity), nullptr,
                         GL_MAP_READ_BIT | GL_CLIENT_STORAGE_BIT);
  }
  // Image stores must land before the pages are read into the buffer.
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT | GL_PIXEL_BUFFER_BARRIER_BIT);
  if (!rect.empty()) {
    // Each part lands at its place in the rect's row-major layout.
    const size_t texel = pixel_size(layer);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glPixelStorei(GL_PACK_ROW_LENGTH, GLint(rect.width()));
    glBindBuffer(GL_PIXEL_PACK_BUFFER, p.pbo.get());
    for (const PagePart& part : parts) {
      const size_t offset =
          size_t((part.rect.y0 - rect.y0) * rect.width() + (part.rect.x0 - rect.x0)) * texel;
      glGetTextureSubImage(pages(layer).texture(), 0, GLint(part.rect.x0 - part.tile.x0),
                           GLint(part.rect.y0 - part.tile.y0), part.page, GLsizei(part.rect.width()),
                           GLsizei(part.rect.height()), 1, GL_RED_INTEGER, pixel_type(layer),
                           GLsizei(p.pixel_bytes - offset), reinterpret_cast<void*>(offset));
      p.pinned.push_back(part.page);
    }
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
  } else {
    for (const PagePart& part : parts) p.pinned.push_back(part.page);
  }
  p.fence = GlSync(glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0));
  glFlush();  // start the work now; collect() only waits
  pending_.push_back(std::move(p));
}

Result<uint64_t> GpuStamper::submit(const QuantizedStamp& q) {
  LOAM_TRY(check_quantized(q, params_, limits_, textures_));
  // Shockwaves bake the Gaussian pulse only.
  auto baked = q.kind == StampKind::kShockwave ? bake_stamp(q, params_) : bake_stamp(q, params_, textures_);
  if (!baked) return baked.error();
  const RectI rect = stamp_rect(q, *baked);
  auto parts = resident_parts(q.layer, rect);
  if (!parts) return parts.error();
  Status st = q.kind == StampKind::kShockwave ? stamp_shockwave(q, *baked, rect, *parts)
                                              : stamp_per_sample(q, *baked, *parts);
  if (!st.ok()) {
    release(q.layer, *parts);
    return st.error();
  }
  if (!options_.read_back) {
    // The caller brings the mirror up to these pages; until then they must stay.
    for (const PagePart& part : *parts) held_.emplace_back(q.layer, part.page);
    return next_ticket_++;
  }
  queue_readback(q.layer, rect, *parts);  // holds the parts' pins until collected
  return pending_.back().ticket;
}

void GpuStamper::end_batch() {
  for (const auto& [layer, page] : held_) pages_mut(layer).unpin(page);
  held_.clear();
}

std::vector<StampReadback> GpuStamper::collect(World& world) {
  std::vector<StampReadback> out;
  while (!pending_.empty()) {
    Pending& p = pending_.front();
    StampReadback done;
    done.ticket = p.ticket;
    done.layer = p.layer;
    if (!p.rect.empty()) {
      // The buffer is only mapped once its fence has signalled: the transfer is complete.
      while (glClientWaitSync(p.fence.get(), GL_SYNC_FLUSH_COMMANDS_BIT, 1'000'000'000) ==
             GL_TIMEOUT_EXPIRED) {
      }
      const void* base = glMapNamedBufferRange(p.pbo.get(), 0, GLsizeiptr(p.pixel_bytes), GL_MAP_READ_BIT);
      // The mirror holds the state before this stamp (earlier tickets are already written),
      // so the samples that differ from it are exactly those the stamp changed. An empty
      // result is RectI{} exactly, as the reference returns it.
      done.changed = visit_layer(p.layer, [&](auto row) {
        using S = typename decltype(row)::Sample;
        return write_readback(world, p.layer, p.rect, static_cast<const S*>(base));
      });
      glUnmapNamedBuffer(p.pbo.get());
    }
    // The mirror now holds what these pages hold: they may be evicted.
    for (int32_t page : p.pinned) pages_mut(p.layer).unpin(page);
    p.pinned.clear();
    out.push_back(done);
    p.fence.reset();
    free_pbos_.push_back(std::move(p));
    pending_.pop_front();
  }
  // A few spare buffers cover steady stamping; more would only hold memory.
  while (free_pbos_.size() > 4) free_pbos_.erase(free_pbos_.begin());
  return out;
}

Result<RectI> GpuStamper::apply(World& world, const QuantizedStamp& q) {
  collect(world);
  auto ticket = submit(q);
  if (!ticket) return ticket.error();
  const std::vector<StampReadback> done = collect(world);
  return done.empty() ? RectI{} : done.back().changed;
}

void GpuStamper::upload(World& world, Layer layer, const RectI& rect) {
  collect(world);
  const RectI r = rect.intersect(layer_rect(layer));
  if (r.empty()) return;
  const TilePages& p = pages(layer);
  const PageFormat f = page_format(layer);
  const RectI tiles = tiles_overlapping(r);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      const auto page = p.find(int32_t(tx), int32_t(ty));
      if (!page) continue;  // filled from the mirror when next needed
      const RectI tile = tile_rect(int32_t(tx), int32_t(ty));
      const RectI part = r.intersect(tile);
      visit_layer(layer, [&](auto row) {
        using R = decltype(row);
        // The part's rows of the tile (an unstored tile: zeros).
        const auto samples = world.tile_samples<R>(TileCoord{R::kLayer, 0, int32_t(tx), int32_t(ty)});
        std::vector<typename R::Sample> data(size_t(part.area()));
        if (!samples.empty()) {
          for (int64_t y = part.y0; y < part.y1; ++y)
            std::copy_n(samples.data() + (y - tile.y0) * kTileSize + (part.x0 - tile.x0), part.width(),
                        data.data() + (y - part.y0) * part.width());
        }
        glTextureSubImage3D(p.texture(), 0, GLint(part.x0 - tile.x0), GLint(part.y0 - tile.y0), *page,
                            GLsizei(part.width()), GLsizei(part.height()), 1, f.format, f.type, data.data());
        traffic_.bytes_uploaded += data.size() * sizeof(typename R::Sample);
      });
    }
  }
}

void GpuStamper::forget(World& world, Layer layer, int32_t tx, int32_t ty) {
  if (!pages(layer).find(tx, ty)) return;
  collect(world);
  pages_mut(layer).drop(tx, ty);
}

std::vector<int32_t> GpuStamper::read_gpu(Layer layer, const RectI& rect) {
  std::vector<int32_t> out;
  const RectI r = rect.intersect(layer_rect(layer));
  if (r.empty()) return out;
  auto parts = resident_parts(layer, r);
  if (!parts) return out;
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  out.resize(size_t(r.area()));
  traffic_.bytes_read_back += size_t(r.area()) * pixel_size(layer);
  for (const PagePart& part : *parts) {
    const size_t n = size_t(part.rect.area());
    const GLint x = GLint(part.rect.x0 - part.tile.x0), y = GLint(part.rect.y0 - part.tile.y0);
    visit_layer(layer, [&](auto row) {
      std::vector<typename decltype(row)::Sample> samples(n);
      glGetTextureSubImage(pages(layer).texture(), 0, x, y, part.page, GLsizei(part.rect.width()),
                           GLsizei(part.rect.height()), 1, GL_RED_INTEGER, pixel_type(layer),
                           GLsizei(n * pixel_size(layer)), samples.data());
      for (int64_t yy = 0; yy < part.rect.height(); ++yy) {
        for (int64_t xx = 0; xx < part.rect.width(); ++xx) {
          out[size_t((part.rect.y0 - r.y0 + yy) * r.width() + (part.rect.x0 - r.x0 + xx))] =
              int32_t(samples[size_t(yy * part.rect.width() + xx)]);
        }
      }
    });
  }
  release(layer, *parts);
  return out;
}

bool GpuStamper::copy_to(Layer layer, const RectI& rect, GLuint dst_texture, int32_t dst_x, int32_t dst_y) {
  auto parts = resident_parts(layer, rect);
  if (!parts) return false;
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  for (const PagePart& part : *parts) {
    glCopyImageSubData(pages(layer).texture(), GL_TEXTURE_2D_ARRAY, 0, GLint(part.rect.x0 - part.tile.x0),
                       GLint(part.rect.y0 - part.tile.y0), part.page, dst_texture, GL_TEXTURE_2D, 0,
                       GLint(dst_x + (part.rect.x0 - rect.x0)), GLint(dst_y + (part.rect.y0 - rect.y0)), 0,
                       GLsizei(part.rect.width()), GLsizei(part.rect.height()), 1);
  }
  release(layer, *parts);
  return true;
}

GpuStamperMemory GpuStamper::memory() const {
  GpuStamperMemory m;
  m.scratch_bytes = 2 * wave_capacity_;
  layers_.for_each([&](Layer l, const GpuLayer& g) {
    m.page_bytes += g.pages.bytes();
    m.scratch_bytes += size_t(g.old_w * g.old_h) * pixel_size(l);
    m.resident_pages[l] = g.pages.resident();
    m.evictions += g.pages.evictions();
  });
  for (const Pending& p : pending_) m.scratch_bytes += p.capacity;
  for (const Pending& p : free_pbos_) m.scratch_bytes += p.capacity;
  return m;
}

}  // namespace loam::gpu
