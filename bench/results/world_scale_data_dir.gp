set terminal pngcairo size 960,600 noenhanced
set output "/work/main/bench/results/world_scale_data_dir.png"
set title "Data folder over a long session"
set xlabel "stamps"
set ylabel "MiB"
set grid
set key outside right top
plot "/work/main/bench/results/world_scale_data_dir.dat" index 0 with linespoints title "data folder MiB", "/work/main/bench/results/world_scale_data_dir.dat" index 1 with linespoints title "snapshots MiB", "/work/main/bench/results/world_scale_data_dir.dat" index 2 with linespoints title "live tiles MiB", "/work/main/bench/results/world_scale_data_dir.dat" index 3 with linespoints title "log MiB"
