# bench_models.gp: draws bench_models.png from bench_models.csv (`ostrich bench models`, see
# bench_models.md): left, wall time per step against nv for copies of MuJoCo's humanoid, both
# engines at the same h (log-log); right, wall time per simulated second of each model, stock
# MuJoCo at its h and Ostrich at h, 5 h and 10 h (runs that failed or were stopped excluded).
# Run from the repository root: gnuplot compare/results/bench_models.gp
set terminal pngcairo size 1400,650 noenhanced
set output 'compare/results/bench_models.png'
set datafile separator ','
set multiplot layout 1,2
set logscale xy
set xlabel 'nv (copies of the humanoid: 1, 2, 5, 10, 22, 100)'
set ylabel 'microseconds per step'
set key left top
set grid
plot '< grep ^scaling compare/results/bench_models.csv | grep ,mujoco,' using 4:11 \
       with linespoints title 'MuJoCo 2.2.2', \
     '< grep ^scaling compare/results/bench_models.csv | grep ,ostrich,' using 4:11 \
       with linespoints title 'Ostrich'
unset logscale x
set logscale y
set xlabel ''
set ylabel 'microseconds per simulated second'
set xtics rotate by 45 right font ',9'
set key outside top center horizontal
# the model rows only (the scaling rows would label the first tic): one MuJoCo row per model
# (its tic), then three Ostrich rows (h, 5 h, 10 h) per model
fm = '< grep ^model, compare/results/bench_models.csv | grep ,mujoco,'
fo = '< grep ^model, compare/results/bench_models.csv | grep ,ostrich,'
name(s) = s[strstrt(s, "/") + 1:]
ok(k) = $7 == k && strcol(16) eq 'ok'
plot fm using 0:(strcol(16) eq 'ok' ? $12 : NaN):xtic(name(strcol(2))) \
       pt 7 ps 1.5 title 'MuJoCo 2.2.2 at h', \
     fo using (ok(1) ? floor($0 / 3) : NaN):12 pt 5 title 'Ostrich at h', \
     fo using (ok(5) ? floor($0 / 3) : NaN):12 pt 9 title 'Ostrich at 5 h', \
     fo using (ok(10) ? floor($0 / 3) : NaN):12 pt 11 title 'Ostrich at 10 h'
unset multiplot
