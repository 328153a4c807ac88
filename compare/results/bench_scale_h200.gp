# bench_scale_h200.gp: draws bench_scale_h200.png from bench_scale_h200.csv (`ostrich bench scale`
# on the H200 machine, see gpu_batch.md): world-iterations per second (rollout + backward pass)
# against the number of worlds, cuda and the CPU batch (16 cores).
# Run from the repository root: gnuplot compare/results/bench_scale_h200.gp
set terminal pngcairo size 900,600
set output 'compare/results/bench_scale_h200.png'
set datafile separator ','
set logscale xy
set xlabel 'worlds'
set ylabel 'world-iterations/s (rollout + backward, 60 steps)'
set key left top
set grid
plot '< grep ^cuda compare/results/bench_scale_h200.csv' using 2:7 with linespoints \
       title 'cuda (H200)', \
     '< grep ^cpu compare/results/bench_scale_h200.csv' using 2:7 with linespoints \
       title 'cpu (16 cores)'
