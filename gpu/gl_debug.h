// GL debug output routed to the log (stderr) in debug builds: the driver's own account of
// invalid calls and performance warnings, which are otherwise silent. A no-op when NDEBUG is
// defined. Call with the context current; safe to call more than once.
#pragma once

namespace loam::gpu {

void install_gl_debug_output();

}  // namespace loam::gpu
