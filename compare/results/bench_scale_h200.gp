# gnuplot '< grep ^cuda compare/results/bench_scale_h200.csv' using 2:7 with linespoints title 'cuda', \
     '< grep ^cpu compare/results/bench_scale_h200.csv' using 2:7 with linespoints title 'cpu (16 cores)'
