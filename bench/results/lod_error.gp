set terminal pngcairo size 960,600 noenhanced
set output "/work/main/bench/results/lod_error.png"
set title "Screen-space error p99 against triangles, every scheme (llvmpipe (LLVM 15.0.6, 256 bits))"
set xlabel "triangles drawn per frame"
set ylabel "p99 screen error (px)"
set grid
set key outside right top
set logscale x
set logscale y
plot "/work/main/bench/results/lod_error.dat" index 0 with linespoints title "clipmap", "/work/main/bench/results/lod_error.dat" index 1 with linespoints title "error clipmap 17", "/work/main/bench/results/lod_error.dat" index 2 with linespoints title "error clipmap 9", "/work/main/bench/results/lod_error.dat" index 3 with linespoints title "full mesh", "/work/main/bench/results/lod_error.dat" index 4 with linespoints title "geomipmap 17", "/work/main/bench/results/lod_error.dat" index 5 with linespoints title "geomipmap 33", "/work/main/bench/results/lod_error.dat" index 6 with linespoints title "geomipmap 65", "/work/main/bench/results/lod_error.dat" index 7 with linespoints title "quadtree 32", "/work/main/bench/results/lod_error.dat" index 8 with linespoints title "quadtree 64", "/work/main/bench/results/lod_error.dat" index 9 with linespoints title "tiled blocks, block-based, skirts", "/work/main/bench/results/lod_error.dat" index 10 with linespoints title "tiled blocks, quadtree-based, index update", "/work/main/bench/results/lod_error.dat" index 11 with linespoints title "tiled blocks, quadtree-based, skirts"
