set terminal pngcairo size 960,600 noenhanced
set output "bench/results/codec_speed.png"
set title "Region codecs: size against speed (all DEM tiles, one core)"
set xlabel "MB/s of raw samples (log)"
set ylabel "bits per sample"
set grid
set key outside right top
set logscale x
plot "bench/results/codec_speed.dat" index 0 with linespoints title "zstd-1 raw", "bench/results/codec_speed.dat" index 1 with linespoints title "zstd-19 raw", "bench/results/codec_speed.dat" index 2 with linespoints title "PNG16 (OIIO)", "bench/results/codec_speed.dat" index 3 with linespoints title "LERC (liblerc)", "bench/results/codec_speed.dat" index 4 with linespoints title "LERC+zstd-9", "bench/results/codec_speed.dat" index 5 with linespoints title "MED+planes+zstd-1", "bench/results/codec_speed.dat" index 6 with linespoints title "MED+planes+zstd-19", "bench/results/codec_speed.dat" index 7 with linespoints title "loam fast", "bench/results/codec_speed.dat" index 8 with linespoints title "loam best"
