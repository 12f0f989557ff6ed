set terminal pngcairo size 960,600 noenhanced
set output "/tmp/lodv2/lod-viewer_error.png"
set title "Screen-space error p99 against triangles, every scheme (llvmpipe (LLVM 15.0.6, 256 bits))"
set xlabel "triangles drawn per frame"
set ylabel "p99 screen error (px)"
set grid
set key outside right top
set logscale x
set logscale y
plot "/tmp/lodv2/lod-viewer_error.dat" index 0 with linespoints title "viewer"
