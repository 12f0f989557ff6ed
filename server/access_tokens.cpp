#include "server/access_tokens.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "protocol/wire/access_token.h"
#include "server/server_config.h"

namespace loam::server {
namespace {

bool contains(const std::vector<wire::AccessToken>& list, const wire::AccessToken& t) {
  bool found = false;
  for (const wire::AccessToken& x : list) found |= wire::access_tokens_equal(x, t);  // no early exit
  return found;
}

}  // namespace

Access check_access(const AccessTokens& tokens, const std::optional<wire::AccessToken>& presented) {
  if (!tokens.required()) return Access::kAsRequested;
  if (tokens.deny_all || !presented) return Access::kDenied;
  if (contains(tokens.editors, *presented)) return Access::kAsRequested;
  if (contains(tokens.viewers, *presented)) return Access::kSpectator;
  return Access::kDenied;
}

Result<AccessTokens> load_access_tokens(const ServerConfig& config) {
  AccessTokens out;
  for (const std::string& t : config.editor_tokens) {
    auto token = wire::parse_access_token(t, "--editor-token");
    if (!token) return token.error();
    out.editors.push_back(*token);
  }
  for (const std::string& t : config.viewer_tokens) {
    auto token = wire::parse_access_token(t, "--viewer-token");
    if (!token) return token.error();
    out.viewers.push_back(*token);
  }
  if (!config.tokens_file.empty()) {
    std::ifstream in(config.tokens_file, std::ios::binary);
    if (!in) return make_error(ErrorCode::kIo, config.tokens_file, "cannot read the tokens file");
    std::ostringstream text;
    text << in.rdbuf();
    LOAM_TRY(wire::parse_token_lines(text.str(), config.tokens_file, out));
    if (out.editors.empty() && out.viewers.empty())
      return make_error(ErrorCode::kInvalidArgument, config.tokens_file,
                        "the tokens file holds no token (an empty file would let everyone edit)");
  }
  return out;
}

std::optional<std::string> tokens_file_exposure(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return std::nullopt;
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) == 0) return std::nullopt;
  char mode[8];
  std::snprintf(mode, sizeof mode, "%04o", unsigned(st.st_mode & 07777));
  return std::string(mode);
}

Status write_private_file(const std::string& path, const std::string& text, bool overwrite) {
  // With overwrite the new text goes to a unique name beside the file first, then is renamed.
  const std::string target = overwrite ? path + ".new-" + std::to_string(::getpid()) : path;
  const int fd = ::open(target.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    const int err = errno;
    if (err == EEXIST && !overwrite)
      return make_error(ErrorCode::kIo, path, "already exists; not overwritten (--force replaces it)");
    return make_error(ErrorCode::kIo, target, std::string("cannot create: ") + std::strerror(err));
  }
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      ::unlink(target.c_str());
      return make_error(ErrorCode::kIo, target, std::string("cannot write: ") + std::strerror(err));
    }
    done += size_t(n);
  }
  const bool synced = ::fsync(fd) == 0;
  const int sync_err = errno;
  const bool closed = ::close(fd) == 0;
  if (!synced || !closed) {
    const int err = synced ? errno : sync_err;
    ::unlink(target.c_str());
    return make_error(ErrorCode::kIo, target, std::string("cannot write: ") + std::strerror(err));
  }
  if (overwrite && std::rename(target.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(target.c_str());
    return make_error(ErrorCode::kIo, path, std::string("cannot replace: ") + std::strerror(err));
  }
  return {};
}

}  // namespace loam::server
