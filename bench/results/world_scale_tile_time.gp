set terminal pngcairo size 960,600 noenhanced
set output "/work/main/bench/results/world_scale_tile_time.png"
set title "Refined tile generation"
set xlabel "mip"
set ylabel "ms per 256^2 tile"
set grid
set key outside right top
plot "/work/main/bench/results/world_scale_tile_time.dat" index 0 with linespoints title "median ms per 256^2 tile", 1 with lines dashtype 2 title "target 1 ms"
