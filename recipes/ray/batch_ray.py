"""Render a Resound jobs file on a Ray cluster: one Ray task per shard.

    python recipes/ray/batch_ray.py JOBS.jsonl OUT_DIR [--shards N] [--address auto]

Each task calls ``resound.batch(jobs, out, shard=(i, N))`` with the Python package, so the
shards split the jobs by model, never write the same file and keep one manifest each
(``OUT_DIR/manifest-<i>-of-<N>.jsonl``). A task lost with its worker is retried by Ray and
resumes from its manifest; rerunning the script skips what is done. The jobs file, its meshes
and OUT_DIR must be on storage every node sees, and every node needs the ``resound`` package
(``pip install ./crates/resound-py``, or a ``runtime_env``). Without ``--address`` the script
starts a local Ray instance (``--num-cpus`` workers).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import ray


@ray.remote(num_cpus=1, max_retries=3)
def render_shard(jobs: str, out: str, i: int, n: int, cache: str | None,
                 library: str | None) -> dict:
    # The modal solve's threads: this task's one CPU (read when the pool starts).
    os.environ.setdefault("RAYON_NUM_THREADS", "1")
    import resound

    return resound.batch(jobs, out, shard=(i, n), cache=cache, library=library)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("jobs", help="jobs file (JSON lines)")
    p.add_argument("out", help="output directory")
    p.add_argument("--shards", type=int, help="tasks (default: the cluster's CPUs)")
    p.add_argument("--address", help="Ray cluster to join ('auto'); default: start a local one")
    p.add_argument("--num-cpus", type=int, help="workers of a local instance")
    p.add_argument("--cache", help="modal model cache (default: OUT/models)")
    p.add_argument("--library", help="material library")
    a = p.parse_args(argv)

    t0 = time.perf_counter()
    if a.address:
        ray.init(address=a.address)
    else:
        ray.init(num_cpus=a.num_cpus, include_dashboard=False)
    n = a.shards or max(1, int(ray.cluster_resources().get("CPU", 1)))
    jobs, out = os.path.abspath(a.jobs), os.path.abspath(a.out)
    cache = os.path.abspath(a.cache) if a.cache else os.path.join(out, "models")
    library = os.path.abspath(a.library) if a.library else None
    refs = [render_shard.remote(jobs, out, i, n, cache, library) for i in range(n)]
    infos = ray.get(refs)
    ray.shutdown()

    failures = sorted((f["line"], f["message"]) for info in infos for f in info["failures"])
    summary = {
        "shards": n,
        "rendered": sum(i["rendered"] for i in infos),
        "skipped": sum(i["skipped"] for i in infos),
        "models_solved": sum(i["models_solved"] for i in infos),
        "failures": [{"line": l, "message": m} for l, m in failures],
        "elapsed_s": time.perf_counter() - t0,
    }
    print(json.dumps(summary))
    for line, message in failures:
        print(f"error: {a.jobs}: line {line}: {message}", file=sys.stderr)
    return 2 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
