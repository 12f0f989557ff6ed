set terminal pngcairo size 960,600 noenhanced
set output "/tmp/bsess/session_latency.png"
set title "Latency against clients"
set xlabel "clients"
set ylabel "milliseconds"
set grid
set key outside right top
set logscale x
plot "/tmp/bsess/session_latency.dat" index 0 with linespoints title "ack p50", "/tmp/bsess/session_latency.dat" index 1 with linespoints title "ack p99", "/tmp/bsess/session_latency.dat" index 2 with linespoints title "fan-out p50", "/tmp/bsess/session_latency.dat" index 3 with linespoints title "fan-out p99", 33.3333 with lines dashtype 2 title "one tick"
