// loam-server export DATA_DIR OUTPUT: a data folder's current world (its newest snapshot and
// log tail, read without changing the folder) as a 16-bit PNG or a float EXR.
#include <cstdio>
#include <memory>

#include "dem/dem_export.h"
#include "protocol/hex64.h"
#include "server/cmd/command.h"
#include "server/storage.h"

namespace loam::server::cmd {

namespace {

int export_world(const std::string& data_dir, const std::string& out) {
  auto opened = read_session(data_dir);
  if (!opened) die(opened.error());
  const World& w = opened->terrain.world();
  const bool exr = out.size() > 4 && out.substr(out.size() - 4) == ".exr";
  const Status st =
      exr ? export_exr(w, w.params().sample_rect(), out) : export_png16(w, w.params().sample_rect(), out);
  if (!st.ok()) die(st.error());
  std::printf("wrote %s (sequence %llu, world hash %s)\n", out.c_str(),
              (unsigned long long)opened->terrain.last_seq(), hex64(w.world_hash()).c_str());
  return 0;
}

}  // namespace

Command add_export(CLI::App& app) {
  auto args = std::make_shared<std::pair<std::string, std::string>>();
  auto* export_cmd = app.add_subcommand("export", "Export a data folder's current world");
  export_cmd->add_option("data_dir", args->first, "Data folder")->required();
  export_cmd->add_option("output", args->second, "Output .png or .exr")->required();
  return {export_cmd, [args] { return export_world(args->first, args->second); }};
}

}  // namespace loam::server::cmd
