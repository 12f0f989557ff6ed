// loam-server pack info|verify PACK: what a tile pack holds; verify decodes every tile and
// checks its hash (exit 3 when one is damaged).
#include <cstdio>
#include <memory>

#include "protocol/base/tile_pack.h"
#include "server/cmd/command.h"

namespace loam::server::cmd {

namespace {

int pack(const std::string& path, bool verify) {
  auto pack = open_tile_pack(path);
  if (!pack) die(pack.error());
  const PackSummary& p = (*pack)->summary();
  std::printf(
      "pack              %s\n"
      "identity          %016llx\n"
      "world             %d x %d tiles at %.6g m/sample, %.6g m/unit, offset %.6f m\n"
      "tiles             %llu over %d mips, %llu bytes\n",
      p.path.c_str(), (unsigned long long)p.identity, p.params.tiles_x, p.params.tiles_y,
      p.params.meters_per_sample, p.params.meters_per_unit, p.params.height_offset,
      (unsigned long long)p.tiles, p.params.mip_count(), (unsigned long long)p.file_bytes);
  if (verify) {
    const Status st = (*pack)->verify();
    if (!st.ok()) {
      std::fprintf(stderr, "damaged: %s\n", st.error().describe().c_str());
      return kExitDamaged;
    }
    std::printf("verified          every tile decodes to its hash\n");
  }
  return 0;
}

}  // namespace

Command add_pack(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  auto* pack_cmd = app.add_subcommand("pack", "Tile packs: what one holds, and a check of every tile");
  pack_cmd->require_subcommand(1);
  auto* info_cmd = pack_cmd->add_subcommand("info", "Parameters, identity, tiles and bytes");
  auto* verify_cmd = pack_cmd->add_subcommand("verify", "Decode every tile and check its hash");
  for (auto* c : {info_cmd, verify_cmd}) c->add_option("pack", *path, "A .loampack file")->required();
  return {pack_cmd, [path, verify_cmd] { return pack(*path, bool(*verify_cmd)); }};
}

}  // namespace loam::server::cmd
