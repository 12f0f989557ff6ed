set terminal pngcairo size 960,600 noenhanced
set output "/work/wt-gdal/bench/results/import_time.png"
set title "DEM import time against size"
set xlabel "megasamples"
set ylabel "milliseconds"
set grid
set key outside right top
set logscale x
set logscale y
plot "/work/wt-gdal/bench/results/import_time.dat" index 0 with linespoints title "read (decode)", "/work/wt-gdal/bench/results/import_time.dat" index 1 with linespoints title "quantize + tile"
