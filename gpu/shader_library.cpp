#include "gpu/shader_library.h"

#include <cstdio>

namespace loam::gpu {

struct EmbeddedShader {
  const char* name;
  const unsigned char* data;
  const unsigned long long* size;
};
// Generated at build time from shaders/*.glsl (gpu/CMakeLists.txt).
extern const EmbeddedShader kEmbeddedShaders[];
extern const int kEmbeddedShaderCount;

std::optional<std::string_view> embedded_shader(std::string_view name) {
  for (int i = 0; i < kEmbeddedShaderCount; ++i) {
    if (name == kEmbeddedShaders[i].name) {
      return std::string_view(reinterpret_cast<const char*>(kEmbeddedShaders[i].data),
                              size_t(*kEmbeddedShaders[i].size));
    }
  }
  return std::nullopt;
}

std::vector<std::string_view> embedded_shader_names() {
  std::vector<std::string_view> out;
  for (int i = 0; i < kEmbeddedShaderCount; ++i) out.emplace_back(kEmbeddedShaders[i].name);
  return out;
}

std::string assemble_shader_source(std::string_view body, std::span<const ShaderDefine> defines) {
  std::string s = "#version 450 core\n";
  for (const ShaderDefine& d : defines) s += "#define " + d.name + " " + d.value + "\n";
  s += "#line 1\n";
  s += body;
  return s;
}

std::string annotate_shader_log(std::string_view log, std::string_view file) {
  const std::string_view files[] = {file};
  return annotate_shader_log(log, std::span<const std::string_view>(files));
}

// Parsed by hand (std::regex trips GCC 12's -Wmaybe-uninitialized under ASan): at the start of
// each line, Mesa writes "N:LINE(COL)" and NVIDIA "N(LINE)", N being the source string.
std::string annotate_shader_log(std::string_view log, std::span<const std::string_view> files) {
  auto digits_end = [](std::string_view s, size_t at) {
    while (at < s.size() && s[at] >= '0' && s[at] <= '9') ++at;
    return at;
  };
  auto name_of = [&](std::string_view index) {
    size_t i = 0;
    for (char c : index) i = i * 10 + size_t(c - '0');
    return index.size() < 6 && i < files.size() ? std::string(files[i]) : std::string(index);
  };
  std::string out;
  size_t start = 0;
  while (true) {
    size_t nl = log.find('\n', start);
    const bool last = nl == std::string_view::npos;
    if (last) nl = log.size();
    const std::string_view line = log.substr(start, nl - start);
    std::string rewritten(line);
    const size_t n_end = digits_end(line, 0);
    if (n_end > 0 && n_end < line.size()) {
      const std::string_view index = line.substr(0, n_end);
      if (line[n_end] == ':') {
        const size_t l_end = digits_end(line, n_end + 1);
        if (l_end > n_end + 1 && l_end < line.size() && line[l_end] == '(') {
          const size_t c_end = digits_end(line, l_end + 1);
          if (c_end > l_end + 1 && c_end < line.size() && line[c_end] == ')') {
            rewritten = name_of(index) + ":" + std::string(line.substr(n_end + 1, l_end - n_end - 1)) + ":" +
                        std::string(line.substr(l_end + 1, c_end - l_end - 1)) +
                        std::string(line.substr(c_end + 1));
          }
        }
      } else if (line[n_end] == '(') {
        const size_t l_end = digits_end(line, n_end + 1);
        if (l_end > n_end + 1 && l_end < line.size() && line[l_end] == ')') {
          rewritten = name_of(index) + ":" + std::string(line.substr(n_end + 1, l_end - n_end - 1)) +
                      std::string(line.substr(l_end + 1));
        }
      }
    }
    out += rewritten;
    if (last) break;
    out += '\n';
    start = nl + 1;
  }
  return out;
}

namespace {

std::string join_names(std::span<const std::string_view> files) {
  std::string out;
  for (std::string_view f : files) out += (out.empty() ? "" : "+") + std::string(f);
  return out;
}

Result<GlShader> compile_files(GLenum stage, std::span<const std::string_view> files,
                               std::span<const ShaderDefine> defines) {
  std::string source = "#version 450 core\n";
  for (const ShaderDefine& d : defines) source += "#define " + d.name + " " + d.value + "\n";
  for (size_t i = 0; i < files.size(); ++i) {
    const auto body = embedded_shader(files[i]);
    if (!body) return make_error(ErrorCode::kNotFound, std::string(files[i]), "no such embedded shader");
    source += "#line 1 " + std::to_string(i) + "\n";
    source += *body;
    source += "\n";
  }
  const std::string name = join_names(files);
  GlShader shader(glCreateShader(stage));
  const char* text = source.c_str();
  glShaderSource(shader.get(), 1, &text, nullptr);
  glCompileShader(shader.get());
  GLint ok = 0, length = 0;
  glGetShaderiv(shader.get(), GL_COMPILE_STATUS, &ok);
  glGetShaderiv(shader.get(), GL_INFO_LOG_LENGTH, &length);
  std::string log;
  if (length > 1) {
    log.resize(size_t(length));
    glGetShaderInfoLog(shader.get(), length, nullptr, log.data());
    log.resize(log.find('\0') == std::string::npos ? log.size() : log.find('\0'));
    log = annotate_shader_log(log, files);
    std::fprintf(stderr, "shader %s: %s\n", name.c_str(), log.c_str());
  }
  if (!ok) return make_error(ErrorCode::kInvalidArgument, name, "compile failed: " + log);
  return shader;
}

Result<GlShader> compile(GLenum stage, std::string_view name, std::span<const ShaderDefine> defines) {
  const std::string_view files[] = {name};
  return compile_files(stage, files, defines);
}

Result<GlProgram> link(std::span<const GLuint> shaders, const std::string& what) {
  GlProgram program(glCreateProgram());
  for (GLuint s : shaders) glAttachShader(program.get(), s);
  glLinkProgram(program.get());
  GLint ok = 0, length = 0;
  glGetProgramiv(program.get(), GL_LINK_STATUS, &ok);
  glGetProgramiv(program.get(), GL_INFO_LOG_LENGTH, &length);
  std::string log;
  if (length > 1) {
    log.resize(size_t(length));
    glGetProgramInfoLog(program.get(), length, nullptr, log.data());
    std::fprintf(stderr, "program %s: %s\n", what.c_str(), log.c_str());
  }
  if (!ok) return make_error(ErrorCode::kInvalidArgument, what, "link failed: " + log);
  return program;
}

}  // namespace

Result<GlProgram> build_compute_program(std::string_view shader, std::span<const ShaderDefine> defines) {
  auto cs = compile(GL_COMPUTE_SHADER, shader, defines);
  if (!cs) return cs.error();
  const GLuint names[] = {cs->get()};
  return link(names, std::string(shader));
}

Result<GlProgram> build_compute_program_from(std::span<const std::string_view> files,
                                             std::span<const ShaderDefine> defines) {
  auto cs = compile_files(GL_COMPUTE_SHADER, files, defines);
  if (!cs) return cs.error();
  const GLuint names[] = {cs->get()};
  return link(names, join_names(files));
}

Result<GlProgram> build_vertex_program_from(std::span<const std::string_view> files,
                                            std::span<const ShaderDefine> defines) {
  auto vs = compile_files(GL_VERTEX_SHADER, files, defines);
  if (!vs) return vs.error();
  const GLuint names[] = {vs->get()};
  return link(names, join_names(files));
}

Result<GlProgram> build_graphics_program(std::string_view vertex_shader, std::string_view fragment_shader,
                                         std::span<const ShaderDefine> defines) {
  const std::string_view vs[] = {vertex_shader}, fs[] = {fragment_shader};
  return build_graphics_program_from(vs, fs, defines);
}

Result<GlProgram> build_graphics_program_from(std::span<const std::string_view> vertex_files,
                                              std::span<const std::string_view> fragment_files,
                                              std::span<const ShaderDefine> defines) {
  auto vs = compile_files(GL_VERTEX_SHADER, vertex_files, defines);
  if (!vs) return vs.error();
  auto fs = compile_files(GL_FRAGMENT_SHADER, fragment_files, defines);
  if (!fs) return fs.error();
  const GLuint names[] = {vs->get(), fs->get()};
  return link(names, join_names(vertex_files) + " + " + join_names(fragment_files));
}

}  // namespace loam::gpu
