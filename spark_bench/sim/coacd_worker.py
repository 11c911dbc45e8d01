"""CoACD worker, run as a script: ``python coacd_worker.py PARAMS_JSON JOB.npz [JOB.npz ...]``.

Each ``JOB.npz`` holds ``vertices`` and ``faces``; the worker writes ``JOB.out.npz`` beside it with the
hulls (concatenated, with per-hull counts) and the CPU seconds spent. Running CoACD in a separate
process keeps a crash in its C++ code (it segfaults on some degenerate inputs) from taking the
caller down, and needs no ``if __name__ == "__main__"`` guard in the caller's script. It imports
nothing from spark-bench, so it starts in a fraction of a second.
"""

from __future__ import annotations

import json
import os
import sys
import time

import numpy as np


def decompose_file(path: str, params: dict) -> None:
    """Decompose the mesh in ``path`` and write ``<path minus .npz>.out.npz`` atomically."""
    import coacd

    with np.load(path) as data:
        vertices, faces = data["vertices"].astype(np.float64), data["faces"].astype(np.int64)
    start = time.process_time()
    parts = coacd.run_coacd(coacd.Mesh(vertices, faces), **params)
    cpu = time.process_time() - start
    hull_v = [np.asarray(v, np.float64) for v, _ in parts]
    hull_f = [np.asarray(f, np.int64) for _, f in parts]
    out = path[: -len(".npz")] + ".out.npz"
    tmp = out + ".tmp.npz"
    np.savez(tmp, vertices=np.concatenate(hull_v) if hull_v else np.zeros((0, 3)),
             faces=np.concatenate(hull_f) if hull_f else np.zeros((0, 3), np.int64),
             n_vertices=np.array([len(v) for v in hull_v], np.int64),
             n_faces=np.array([len(f) for f in hull_f], np.int64), cpu=np.array(cpu))
    os.replace(tmp, out)


def main(argv: list[str]) -> int:
    import coacd

    coacd.set_log_level("error")
    params = json.loads(argv[0])
    for path in argv[1:]:
        decompose_file(path, params)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
