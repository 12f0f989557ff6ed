// The GLSL sources of shaders/, embedded into the binary at build time (no runtime path
// lookup), and the program builder: a #version line and feature defines are prepended,
// `#line 1` keeps line numbers those of the file, and compile or link logs name the file
// and line. Logs are printed even on success (warnings matter).
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/gl_handle.h"
#include "protocol/result.h"

namespace loam::gpu {

// Source of an embedded shader by file name ("stamp.comp.glsl"), or nullopt.
std::optional<std::string_view> embedded_shader(std::string_view name);
std::vector<std::string_view> embedded_shader_names();

struct ShaderDefine {
  std::string name;
  std::string value;
};

// The full text handed to the GL compiler: version, defines, #line 1, then the file.
std::string assemble_shader_source(std::string_view body, std::span<const ShaderDefine> defines);

// Compiles and links a compute program from an embedded shader. Errors name the shader
// file and line ("stamp.comp.glsl:12: ...").
Result<GlProgram> build_compute_program(std::string_view shader, std::span<const ShaderDefine> defines = {});

// Compiles and links a compute program from several embedded files concatenated in order
// (shared helpers first, e.g. {"stamp_common.glsl", "stamp.comp.glsl"}). Each file starts
// with "#line 1 N" (N its index), so errors still name the right file and line.
Result<GlProgram> build_compute_program_from(std::span<const std::string_view> files,
                                             std::span<const ShaderDefine> defines = {});

// Compiles and links a program with only a vertex stage from several embedded files, as
// build_compute_program_from (for vertex shaders that work through image stores and draw
// nothing).
Result<GlProgram> build_vertex_program_from(std::span<const std::string_view> files,
                                            std::span<const ShaderDefine> defines = {});

// Compiles and links a vertex + fragment program from embedded shaders.
Result<GlProgram> build_graphics_program(std::string_view vertex_shader, std::string_view fragment_shader,
                                         std::span<const ShaderDefine> defines = {});
// The same, each stage from several files concatenated in order (shared declarations, such
// as uniform blocks, first), as build_compute_program_from.
Result<GlProgram> build_graphics_program_from(std::span<const std::string_view> vertex_files,
                                              std::span<const std::string_view> fragment_files,
                                              std::span<const ShaderDefine> defines = {});

// Rewrites a driver info log's "0:LINE(COL)" or "0(LINE)" prefixes into "FILE:LINE".
std::string annotate_shader_log(std::string_view log, std::string_view file);
// The same for a source made of several files: "N:LINE(COL)" names files[N].
std::string annotate_shader_log(std::string_view log, std::span<const std::string_view> files);

}  // namespace loam::gpu
