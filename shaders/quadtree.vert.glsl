// Ulrich's adaptive quadtree (client/lod/quadtree.h): the CPU builds each block's mesh with its
// vertices' drawn heights (morphs applied) and re-uploads only the blocks that changed; this
// stage places them. Block origin relative to the camera comes as an instanced attribute (the
// draw's base instance selects it). Shares the geomipmap program's frame block and shading.
layout(location = 0) in vec3 a_vertex;  // block-local sample x, y; height in height units
layout(location = 1) in vec2 a_origin;  // the block's origin relative to the camera (render frame, m)

out vec3 v_rel;
out float v_height;

void main() {
  float z = g_scale.z + a_vertex.z * g_scale.y;
  v_rel = vec3(a_origin.x + a_vertex.x * g_scale.x, a_origin.y - a_vertex.y * g_scale.x, z);
  v_height = a_vertex.z * g_scale.y;
  gl_Position = g_view_proj * vec4(v_rel, 1.0);
}
