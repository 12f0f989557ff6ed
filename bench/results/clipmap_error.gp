set terminal pngcairo size 960,600 noenhanced
set output "/work/main/bench/results/clipmap_error.png"
set title "Clipmap: screen-space error p99 and frame time against triangles (llvmpipe (LLVM 15.0.6, 256 bits))"
set xlabel "triangles drawn per frame"
set ylabel "p99 error (px) / frame time (ms)"
set grid
set key outside right top
set logscale x
set logscale y
plot "/work/main/bench/results/clipmap_error.dat" index 0 with linespoints title "screen-space error p99 (px)", "/work/main/bench/results/clipmap_error.dat" index 1 with linespoints title "frame time, steady (ms)"
