"""The tools ``benchmarks/bench_engine.py`` times, one module each.

:mod:`.timing` holds what every tool shares (the workload's constants, the timed loop,
the exact overlap, the memory measure, the common start); :mod:`.ours`,
:mod:`.numpy_bench`, :mod:`.pymunk_bench`, :mod:`.jaxmd_bench` and :mod:`.vmas_bench`
each build one tool on that workload and return :func:`.timing.timed`'s measures.  The
table, the estimates of cells not run and the command line are in ``bench_engine.py``.
"""
