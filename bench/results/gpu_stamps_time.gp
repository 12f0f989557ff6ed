set terminal pngcairo size 960,600 noenhanced
set output "/work/main/bench/results/gpu_stamps_time.png"
set title "Stamp time against radius (llvmpipe (LLVM 15.0.6, 256 bits))"
set xlabel "radius (m)"
set ylabel "milliseconds"
set grid
set key outside right top
set logscale x
set logscale y
plot "/work/main/bench/results/gpu_stamps_time.dat" index 0 with linespoints title "CPU scalar reference", "/work/main/bench/results/gpu_stamps_time.dat" index 1 with linespoints title "CPU optimized (stamp_fast)", "/work/main/bench/results/gpu_stamps_time.dat" index 2 with linespoints title "GPU stamp only", "/work/main/bench/results/gpu_stamps_time.dat" index 3 with linespoints title "GPU stamp + dirty-rect readback"
