"""Benchmark: ``doodle batch`` on procedural scenes (one broken) with the local engine and, when Ray is
installed, the Ray engine — objects an hour, the rerun's cost, and whether both engines made the same files.

Run: ``python benchmarks/bench_batch.py [--scenes snowman,mug,parcel,cow] [--train 24] [--size 192]
[--jobs 0] [--no-ray]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from doodle.batch import BatchOptions, run_batch
from doodle.samples import write_sample
from doodle.workers import cpu_count


def outputs(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != "record.json"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenes", default="snowman,mug,parcel,cow")
    ap.add_argument("--train", type=int, default=24)
    ap.add_argument("--size", type=int, default=192)
    ap.add_argument("--jobs", type=int, default=0)
    ap.add_argument("--no-ray", action="store_true")
    args = ap.parse_args()
    root = Path(tempfile.mkdtemp(prefix="doodle-bench-batch-"))
    names = args.scenes.split(",")
    for name in names:
        write_sample(name, root / name, n_train=args.train, n_test=4, size=args.size)
    (root / "broken").mkdir()
    (root / "broken" / "transforms_train.json").write_text("{}")
    manifest = root / "objects.toml"
    manifest.write_text("[defaults]\nviews = 12\nframes = 24\n\n"
                        + "".join(f'[[objects]]\nscene = "{n}"\n\n' for n in names + ["broken"]))
    print(f"{len(names)} scenes + 1 broken, {args.train} views at {args.size} px, on {cpu_count()} cores")
    engines = [("local", BatchOptions(jobs=args.jobs))]
    try:
        import ray  # noqa: F401

        if not args.no_ray:
            engines.append(("ray", BatchOptions(ray="auto")))
    except ImportError:
        print("ray: not installed (pip install -e '.[ray]')")
    made = {}
    for label, opt in engines:
        out = root / f"out-{label}"
        t0 = time.perf_counter()
        result = run_batch(manifest, out, opt, log=lambda m: None)
        seconds = time.perf_counter() - t0
        t0 = time.perf_counter()
        again = run_batch(manifest, out, opt, log=lambda m: None)
        rerun = time.perf_counter() - t0
        ok = len(result.records) - len(result.failed)
        print(f"{label:5s}: {ok} made + {len(result.failed)} failed in {seconds:.0f} s = "
              f"{result.made / seconds * 3600:.0f} objects/h (of which {ok / seconds * 3600:.0f} made); "
              f"rerun {rerun:.1f} s, {again.made} made")
        made[label] = out
    if len(made) == 2:
        same = all(outputs(made["local"] / n) == outputs(made["ray"] / n) for n in names)
        print(f"local and Ray outputs identical: {same}")


if __name__ == "__main__":
    main()
