"""Speed of the procedural generator, against loading the same objects back (the peer, same run).

Run: ``python -m benchmarks.measure_synth [--per-category K]``. Prints seconds per object for
sampling + clearance repair, for writing, and for ``load_object`` of the written folder, and ratios.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from spark_bench.data import load_object
from spark_bench.data.synth import CATEGORIES, build_object, object_seed
from spark_bench.data.synth.generate import GENERATOR_VERSION
from spark_bench.data.synth.writer import write_object


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-category", type=int, default=3)
    args = parser.parse_args()
    build_s = write_s = load_s = 0.0
    count = 0
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.per_category):
            for i, category in enumerate(CATEGORIES):
                seed = object_seed(0, k * len(CATEGORIES) + i)
                t0 = time.perf_counter()
                spec, attempt = build_object(category, seed)
                t1 = time.perf_counter()
                folder = write_object(spec, Path(tmp) / f"{category}_{k}", f"{category}_{k}",
                                      {"seed": seed, "attempt": attempt, "version": GENERATOR_VERSION})
                t2 = time.perf_counter()
                load_object(folder)
                t3 = time.perf_counter()
                build_s, write_s, load_s, count = build_s + t1 - t0, write_s + t2 - t1, load_s + t3 - t2, count + 1
    print(f"objects: {count} ({len(CATEGORIES)} categories)")
    print(f"sample + clearance repair: {build_s / count * 1e3:7.1f} ms/object")
    print(f"write folder:              {write_s / count * 1e3:7.1f} ms/object")
    print(f"load_object (peer):        {load_s / count * 1e3:7.1f} ms/object")
    print(f"generate / load ratio:     {(build_s + write_s) / load_s:7.2f}")


if __name__ == "__main__":
    main()
