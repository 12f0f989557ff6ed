// Gradient map of the detail layer around the camera (client/render/clipmap_renderer.h): central
// differences of the toroidal R8I offsets (detail sample p at texel p mod tex_size), in meters
// per meter, into a filtered RG16F texture the fragment shader perturbs normals with.
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform isampler2D offsets;  // R8I, tex_size^2
layout(rg16f, binding = 1) uniform writeonly image2D gradient;

// Mirrored by DetailGradientBlock (client/render/clipmap_blocks.h), checked at creation.
layout(std140, binding = 2) uniform DetailGradient {
  ivec4 rect;         // detail samples [x0, x1) x [y0, y1); each has both neighbours loaded
  ivec2 region_lo;    // the region's first sample (every p read or written is in the region)
  ivec2 region_base;  // its texel, region_lo mod tex_size
  int tex_size;
  float scale;        // detail meters per unit / (2 * detail spacing in meters)
  int pad0;
  int pad1;
};

// GLSL's % is undefined for negative operands: offset from the region's corner first.
ivec2 texel(ivec2 p) { return (region_base + (p - region_lo)) % tex_size; }
float d(ivec2 p) { return float(texelFetch(offsets, texel(p), 0).r); }

void main() {
  ivec2 p = rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= rect.z || p.y >= rect.w) return;
  vec2 g = vec2(d(p + ivec2(1, 0)) - d(p - ivec2(1, 0)), d(p + ivec2(0, 1)) - d(p - ivec2(0, 1))) * scale;
  imageStore(gradient, texel(p), vec4(g, 0.0, 0.0));
}
