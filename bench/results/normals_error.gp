set terminal pngcairo size 960,600 noenhanced
set output "/work/main/bench/results/normals_error.png"
set title "Largest angle error against the steepest slope, 16 samples per wavelength, exact heights"
set xlabel "steepest slope (degrees)"
set ylabel "max angle error (degrees)"
set grid
set key outside right top
set logscale y
plot "/work/main/bench/results/normals_error.dat" index 0 with linespoints title "FD2", "/work/main/bench/results/normals_error.dat" index 1 with linespoints title "FD4", "/work/main/bench/results/normals_error.dat" index 2 with linespoints title "FD4, packed RG16 (Loam's normal maps)", "/work/main/bench/results/normals_error.dat" index 3 with linespoints title "Horn 3x3 (gdaldem)", "/work/main/bench/results/normals_error.dat" index 4 with linespoints title "8-bit partial derivatives (deformable-terrain paper)"
