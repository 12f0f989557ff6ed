set terminal pngcairo size 960,600 noenhanced
set output "/work/wt-codec/bench/results/codec_speed.png"
set title "Region codecs: size against speed (all DEM tiles, one core)"
set xlabel "MB/s of raw samples (log)"
set ylabel "bits per sample"
set grid
set key outside right top
set logscale x
plot "/work/wt-codec/bench/results/codec_speed.dat" index 0 with linespoints title "zstd-1 raw", "/work/wt-codec/bench/results/codec_speed.dat" index 1 with linespoints title "zstd-19 raw", "/work/wt-codec/bench/results/codec_speed.dat" index 2 with linespoints title "PNG16 (OIIO)", "/work/wt-codec/bench/results/codec_speed.dat" index 3 with linespoints title "LERC (liblerc)", "/work/wt-codec/bench/results/codec_speed.dat" index 4 with linespoints title "LERC+zstd-9", "/work/wt-codec/bench/results/codec_speed.dat" index 5 with linespoints title "MED+planes+zstd-1", "/work/wt-codec/bench/results/codec_speed.dat" index 6 with linespoints title "MED+planes+zstd-19", "/work/wt-codec/bench/results/codec_speed.dat" index 7 with linespoints title "loam fast", "/work/wt-codec/bench/results/codec_speed.dat" index 8 with linespoints title "loam best"
