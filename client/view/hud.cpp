#include "client/view/hud.h"

#include <imgui.h>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>

namespace loam::view {

namespace {

constexpr ImGuiWindowFlags kPanel = ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoFocusOnAppearing |
                                    ImGuiWindowFlags_NoSavedSettings;

ImTextureID texture_id(const gpu::GlTexture& t) { return reinterpret_cast<ImTextureID>(uintptr_t(t.get())); }

void legend_entry(terrain::TileState s, int64_t n) {
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const float h = ImGui::GetTextLineHeight();
  ImGui::GetWindowDrawList()->AddRectFilled(p, ImVec2(p.x + h, p.y + h),
                                            terrain::tile_state_colour(s) | 0xFF000000u);
  ImGui::Dummy(ImVec2(h, h));
  ImGui::SameLine();
  ImGui::Text("%s %" PRId64, to_string(s), n);
}

}  // namespace

void draw_status_panel(const HudStatus& s) {
  const render::ViewerStats& v = s.session;
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_Always);
  ImGui::SetNextWindowBgAlpha(0.6f);
  ImGui::Begin("Loam", nullptr, kPanel);
  ImGui::Text("%s", s.renderer.c_str());
  ImGui::Text("frame %.1f ms (%.0f fps), %lld triangles, %d draw calls", s.frame_ms,
              1000.0 / std::max(s.frame_ms, 0.01), (long long)s.triangles, s.draw_calls);
  if (s.lod_budget_px > 0) ImGui::Text("screen error within %.2f px", s.lod_budget_px);
  ImGui::Text("%s %.1f, %.1f, %.1f m, speed %.0f m/s", s.walking ? "walking at" : "camera", s.camera_x,
              s.camera_y, s.camera_z, s.speed_mps);
  ImGui::Separator();
  if (v.rtt_ms >= 0) {
    ImGui::Text("RTT %.1f ms, server tick p50 %.2f / p99 %.2f ms, %u clients", v.rtt_ms,
                v.server_tick_p50_us / 1000.0, v.server_tick_p99_us / 1000.0, v.server_clients);
  } else {
    ImGui::Text("RTT: waiting for the first answer");
  }
  // Bytes in against the budget the server streams to this client within.
  char bytes[96];
  if (v.budget_bytes_per_s > 0) {
    std::snprintf(bytes, sizeof bytes, "in %.1f of %.0f KiB/s", v.bytes_in_per_s / 1024.0,
                  v.budget_bytes_per_s / 1024.0);
    ImGui::ProgressBar(float(std::clamp(v.bytes_in_per_s / v.budget_bytes_per_s, 0.0, 1.0)), ImVec2(320, 0),
                       bytes);
  } else {
    ImGui::Text("in %.1f KiB/s", v.bytes_in_per_s / 1024.0);
  }
  ImGui::Text("tiles %llu held of %llu subscribed, %llu regions", (unsigned long long)v.tiles_held,
              (unsigned long long)v.tiles_subscribed, (unsigned long long)v.regions);
  ImGui::Text("events %llu applied, %llu stamped on the GPU, %llu copied",
              (unsigned long long)v.events_applied, (unsigned long long)v.display.events_stamped,
              (unsigned long long)v.display.events_copied);
  ImGui::Text("own stamps %zu unsettled, %llu predicted, %llu corrected", v.overlay,
              (unsigned long long)v.display.predicted, (unsigned long long)v.display.corrections);
  ImGui::Text("hash checks %llu, mismatches %llu, divergent texels %llu", (unsigned long long)v.hash_checks,
              (unsigned long long)v.hash_mismatches, (unsigned long long)v.display.divergent_texels);
  ImGui::Text("terrain memory: GPU %.1f MiB (%d tile pages), CPU %.1f MiB",
              double(v.gpu_terrain_bytes) / (1 << 20), v.gpu_pages_resident,
              double(v.cpu_terrain_bytes) / (1 << 20));
  ImGui::TextDisabled("WASD/QE move, shift fast, right-drag look, G walk, Space jump");
  ImGui::TextDisabled("left-click stamp, 1-6 presets, wheel radius, Z/X C/V sun, F1 HUD, F12 screenshot");
  ImGui::End();
}

void draw_minimap_panel(const terrain::Minimap& map, const terrain::TileStateCounts& counts) {
  const ImGuiIO& io = ImGui::GetIO();
  ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x - 8, 8), ImGuiCond_Always, ImVec2(1, 0));
  ImGui::SetNextWindowBgAlpha(0.6f);
  ImGui::Begin("Map", nullptr, kPanel);
  const ImVec2 o = ImGui::GetCursorScreenPos();
  ImDrawList* d = ImGui::GetWindowDrawList();
  auto at = [&](float x, float y) { return ImVec2(o.x + x, o.y + y); };
  d->AddRectFilled(o, at(map.size_px, map.size_px), IM_COL32(20, 24, 30, 255));
  d->PushClipRect(o, at(map.size_px, map.size_px), true);
  for (const terrain::MinimapRect& r : map.coarse_tiles) {
    d->AddRectFilled(at(r.x0, r.y0), at(r.x1, r.y1), r.colour);
    d->AddRect(at(r.x0, r.y0), at(r.x1, r.y1), IM_COL32(0, 0, 0, 90));
  }
  for (const terrain::MinimapRect& r : map.detail_tiles)
    d->AddRect(at(r.x0, r.y0), at(r.x1, r.y1), r.colour | 0xFF000000u);
  if (map.world)
    d->AddRect(at(map.world->x0, map.world->y0), at(map.world->x1, map.world->y1), map.world->colour, 0, 0,
               2);
  for (const terrain::MinimapRect& r : map.levels) d->AddRect(at(r.x0, r.y0), at(r.x1, r.y1), r.colour);
  const auto& f = map.frustum;
  d->AddTriangleFilled(at(f[0][0], f[0][1]), at(f[1][0], f[1][1]), at(f[2][0], f[2][1]),
                       IM_COL32(255, 255, 255, 40));
  d->AddTriangle(at(f[0][0], f[0][1]), at(f[1][0], f[1][1]), at(f[2][0], f[2][1]),
                 IM_COL32(255, 255, 255, 220), 1.5f);
  d->AddCircleFilled(at(f[0][0], f[0][1]), 3.5f, IM_COL32(255, 80, 40, 255));
  d->PopClipRect();
  ImGui::Dummy(ImVec2(map.size_px, map.size_px));
  ImGui::Text("%.0f m across, %zu levels", map.meters_per_pixel * map.size_px, map.levels.size());
  legend_entry(terrain::TileState::kHeld, counts.held);
  ImGui::SameLine(0, 12);
  legend_entry(terrain::TileState::kPending, counts.pending);
  legend_entry(terrain::TileState::kStale, counts.stale);
  ImGui::SameLine(0, 12);
  legend_entry(terrain::TileState::kEvicted, counts.evicted);
  ImGui::End();
}

bool draw_tool_panel(controls::StampTool& tool, std::span<const wire::StampImageListEntry> images,
                     const StampPreviews& previews) {
  const ImGuiIO& io = ImGui::GetIO();
  ImGui::SetNextWindowPos(ImVec2(8, io.DisplaySize.y - 8), ImGuiCond_Always, ImVec2(0, 1));
  ImGui::SetNextWindowBgAlpha(0.6f);
  ImGui::Begin("Stamp tool", nullptr, kPanel);
  bool changed = false;
  for (int i = 0; i < controls::kToolCount; ++i) {
    if (i > 0) ImGui::SameLine();
    char label[32];
    std::snprintf(label, sizeof label, "%d %s", i + 1, to_string(controls::Tool(i)));
    if (ImGui::SmallButton(label)) {
      tool.select(controls::Tool(i));
      changed = true;
    }
  }
  ImGui::PushItemWidth(220);
  int kind = int(tool.kind);
  const char* kinds[kStampKindCount];
  for (int k = 0; k < kStampKindCount; ++k) kinds[k] = to_string(StampKind(k));
  if (ImGui::Combo("kind", &kind, kinds, kStampKindCount)) {
    tool.set_kind(StampKind(kind));
    changed = true;
  }
  int layer = int(tool.layer);
  changed |= ImGui::RadioButton("coarse", &layer, int(Layer::kCoarse));
  ImGui::SameLine();
  changed |= ImGui::RadioButton("detail", &layer, int(Layer::kDetail));
  tool.layer = Layer(layer);
  const bool own = tool.kind == StampKind::kFootprint || tool.kind == StampKind::kFlatten ||
                   tool.kind == StampKind::kShockwave;
  if (own) {
    tool.blend = BlendMode::kAdd;
    ImGui::TextDisabled("blend: its own");
  } else {
    int blend = int(tool.blend);
    const char* blends[kBlendModeCount];
    for (int b = 0; b < kBlendModeCount; ++b) blends[b] = to_string(BlendMode(b));
    if (ImGui::Combo("blend", &blend, blends, kBlendModeCount)) {
      tool.blend = BlendMode(blend);
      changed = true;
    }
  }
  float radius = float(tool.radius_m);
  if (ImGui::SliderFloat("radius m", &radius, float(tool.min_radius_m), float(tool.max_radius_m), "%.1f",
                         ImGuiSliderFlags_Logarithmic)) {
    tool.radius_m = double(radius);
    changed = true;
  }
  float intensity = float(tool.intensity);
  const bool strength = tool.kind == StampKind::kFlatten;
  if (ImGui::SliderFloat(strength ? "strength" : "intensity m", &intensity, strength ? 0.0f : -100.0f,
                         strength ? 1.0f : 100.0f, "%.2f")) {
    tool.intensity = double(intensity);
    changed = true;
  }
  float rotation = float(tool.rotation_degrees);
  if (ImGui::SliderFloat("rotation", &rotation, 0.0f, 360.0f, "%.0f deg")) {
    tool.rotation_degrees = double(rotation);
    changed = true;
  }
  ImGui::SameLine();
  changed |= ImGui::Checkbox("spin", &tool.spin);
  if (tool.kind == StampKind::kCrater || tool.kind == StampKind::kFootprint ||
      tool.kind == StampKind::kFlatten) {
    float shape = float(tool.shape);
    if (ImGui::SliderFloat(tool.kind == StampKind::kCrater ? "rim" : "edge", &shape, 0.0f, 1.0f, "%.2f")) {
      tool.shape = double(shape);
      changed = true;
    }
  }
  if (tool.kind == StampKind::kCrater) {
    changed |=
        ImGui::Checkbox("volume-conserving (the rim holds what the bowl digs out)", &tool.volume_conserving);
    if (tool.volume_conserving && tool.blend != BlendMode::kAdd && tool.blend != BlendMode::kSubtract)
      tool.blend = BlendMode::kAdd;
  }
  if (tool.kind == StampKind::kShockwave) {
    int steps = int(tool.steps);
    if (ImGui::SliderInt("steps", &steps, 1, 400)) {
      tool.steps = uint32_t(steps);
      changed = true;
    }
    float speed = float(tool.speed), damping = float(tool.damping);
    if (ImGui::SliderFloat("speed", &speed, 0.05f, 0.99f, "%.2f")) tool.speed = double(speed), changed = true;
    if (ImGui::SliderFloat("damping", &damping, 0.0f, 0.5f, "%.3f"))
      tool.damping = double(damping), changed = true;
  }
  ImGui::PopItemWidth();
  if (tool.kind == StampKind::kTexture) {
    ImGui::Text("image (%zu registered on the server):", images.size());
    if (images.empty()) ImGui::TextDisabled("the server has none: start it with --stamp-image");
    int shown = 0;
    for (const wire::StampImageListEntry& e : images) {
      if (shown++ % 4 != 0) ImGui::SameLine();
      ImGui::PushID(int(shown));
      ImGui::BeginGroup();
      const bool selected = tool.texture_id == e.image_id;
      if (const StampPreview* p = previews.find(e.image_id)) {
        const float w = 56.0f * float(p->width) / float(std::max(p->width, p->height));
        const float h = 56.0f * float(p->height) / float(std::max(p->width, p->height));
        if (ImGui::ImageButton(texture_id(p->texture), ImVec2(w, h), ImVec2(0, 0), ImVec2(1, 1),
                               selected ? 3 : 1,
                               selected ? ImVec4(1.0f, 0.6f, 0.1f, 1.0f) : ImVec4(0, 0, 0, 0))) {
          tool.texture_id = e.image_id;
          changed = true;
        }
      } else if (ImGui::Button("not\nserved", ImVec2(62, 62))) {
        tool.texture_id = e.image_id;  // stamped by id; the server has it
        changed = true;
      }
      ImGui::Text("%ux%u", e.width, e.height);
      ImGui::EndGroup();
      ImGui::PopID();
    }
  }
  ImGui::End();
  return changed;
}

}  // namespace loam::view
