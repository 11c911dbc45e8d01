"""The benchmark run: the eval runner (:mod:`.runner`) with what it hands a worker (:mod:`.tasks`) and what a
worker does with one case (:mod:`.case_eval`), the executors (:mod:`.executors`: a process pool;
:mod:`spark_bench.ray_executor`: Ray), the SQLite results store (:mod:`.store`, resuming: :mod:`.resume`), per-benchmark
aggregation (:mod:`.aggregate`) and the leaderboard (:mod:`.board`, :mod:`.leaderboard`,
:mod:`.leaderboard_html`, :mod:`.render`); CLI in :mod:`.commands`."""
