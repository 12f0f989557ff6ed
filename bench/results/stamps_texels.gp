set terminal pngcairo size 960,600 noenhanced
set output "/work/main/bench/results/stamps_texels.png"
set title "Stamp throughput"
set xlabel "radius (samples)"
set ylabel "Mtexels/s"
set grid
set key outside right top
set logscale x
set logscale y
plot "/work/main/bench/results/stamps_texels.dat" index 0 with linespoints title "gaussian", "/work/main/bench/results/stamps_texels.dat" index 1 with linespoints title "crater", "/work/main/bench/results/stamps_texels.dat" index 2 with linespoints title "flatten", "/work/main/bench/results/stamps_texels.dat" index 3 with linespoints title "footprint", "/work/main/bench/results/stamps_texels.dat" index 4 with linespoints title "gaussian (scalar reference)", "/work/main/bench/results/stamps_texels.dat" index 5 with linespoints title "shockwave"
