"""The benchmark run: the eval runner (:mod:`.runner`), the SQLite results store (:mod:`.store`),
per-benchmark aggregation (:mod:`.aggregate`), the opening tests (:mod:`.opening`) and the leaderboard
(:mod:`.leaderboard`, :mod:`.leaderboard_html`, :mod:`.render`); CLI in :mod:`.commands`."""
