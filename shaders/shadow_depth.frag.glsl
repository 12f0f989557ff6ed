// The sun's shadow pass: depth only (the clipmap vertex stage with the light's view_proj).
void main() {}
