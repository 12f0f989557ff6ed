// GL test only (tests/gl/gpu_stamp_cases_test.cpp; stamp_common.glsl is prepended): evaluates
// one of stamp_common.glsl's float-estimate-plus-correction helpers per invocation, so the
// test can hold it to the exact integer answer over the inputs where a correction matters.
// MODE 0: isqrt_small(inputs[i].x); MODE 1: div_q16(inputs[i].x, inputs[i].y).
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Inputs { ivec2 inputs[]; };
layout(std430, binding = 1) writeonly buffer Outputs { int outputs[]; };

uniform int count;

void main() {
  int i = int(gl_GlobalInvocationID.x);
  if (i >= count) return;
  ivec2 a = inputs[i];
#if MODE == 0
  outputs[i] = isqrt_small(a.x);
#else
  outputs[i] = div_q16(a.x, a.y, 1.0 / float(a.y));
#endif
}
