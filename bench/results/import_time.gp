set terminal pngcairo size 960,600 noenhanced
set output "bench/results/import_time.png"
set title "DEM import time against size"
set xlabel "megasamples"
set ylabel "milliseconds"
set grid
set key outside right top
set logscale x
set logscale y
plot "bench/results/import_time.dat" index 0 with linespoints title "read (decode)", "bench/results/import_time.dat" index 1 with linespoints title "quantize + tile"
