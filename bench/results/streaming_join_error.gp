set terminal pngcairo size 960,600 noenhanced
set output "bench/results/streaming_join_error.png"
set title "View error while joining at 128 KiB/s"
set xlabel "seconds"
set ylabel "meters"
set grid
set key outside right top
set logscale y
plot "bench/results/streaming_join_error.dat" index 0 with linespoints title "mean", "bench/results/streaming_join_error.dat" index 1 with linespoints title "max"
