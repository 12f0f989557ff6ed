// GL self-test: integer arithmetic in a compute shader, used by the GL tests to prove the
// context compiles shaders, honours prepended defines and returns exact integers.
layout(local_size_x = 64) in;

layout(std430, binding = 0) buffer Data {
  int values[];
};

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(values.length())) return;
  // Exact integer work: a multiply-shift the CPU reproduces bit for bit.
  int v = values[i];
  values[i] = ((v * SELFTEST_MULTIPLIER) >> 3) - int(i);
}
