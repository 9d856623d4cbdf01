"""Compares caustic's CPU time per iteration with SmallVCM's on the four SmallVCM
scenes (the speed targets of issue 4), alternating the programs in every round so
that both see the same load. Not used by the tests.

SmallVCM (Davidovic and Georgiev, MIT licence) is built from its own sources as its
Makefile does, e.g. `g++ -O3 -std=c++0x -fopenmp -o smallvcm src/smallvcm.cxx`; a
second build with `-march=native -ffast-math` is a stricter reference. Give each
build with --smallvcm:

    cargo build --release
    python3 deploy/scripts/smallvcm_compare.py --smallvcm /path/smallvcm \\
        --smallvcm /path/smallvcm-native --rounds 3

SmallVCM runs whole iterations on each of its threads (one per processor), so it
renders --iterations (default 4, two per thread on two cores) with every core busy;
its user + system time over the iterations is the figure. caustic's is the CPU
s/iteration that `caustic bench --spp 2` prints, also with every core busy. The
table gives medians over the rounds, and each ratio is the median of the per-round
ratios of caustic to that build.
"""

import argparse
import os
import resource
import statistics
import subprocess
import tempfile

SCENES = ["gbs_s", "glm_c", "gbs_p", "gbs_b"]  # SmallVCM's scene ids 0-3


def smallvcm_cpu(binary, scene, algorithm, iterations):
    """CPU seconds per iteration of one SmallVCM run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(
        [binary, "-s", str(scene), "-a", algorithm, "-i", str(iterations),
         "-o", os.path.join(tempfile.gettempdir(), "smallvcm_compare.bmp")],
        check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu / iterations


def caustic_cpu(binary, scene, algorithm):
    """CPU seconds per iteration that `caustic bench` reports."""
    out = subprocess.run(
        [binary, "bench", f"scenes/smallvcm/{scene}.json", "--algorithms", algorithm,
         "--spp", "2", "--repeat", "1"],
        check=True, capture_output=True, text=True).stdout
    return float(out.strip().splitlines()[-1].split()[2])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--smallvcm", action="append", required=True,
                    help="a SmallVCM binary (repeat for several builds)")
    ap.add_argument("--caustic", default="target/release/caustic")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--iterations", type=int, default=4)
    ap.add_argument("--scenes", nargs="+", default=SCENES, choices=SCENES)
    ap.add_argument("--algorithms", nargs="+", default=["pt", "bpt", "vcm"])
    a = ap.parse_args()
    runs = {}
    for _ in range(a.rounds):
        for scene in a.scenes:
            for alg in a.algorithms:
                refs = [smallvcm_cpu(b, SCENES.index(scene), alg, a.iterations)
                        for b in a.smallvcm]
                ours = caustic_cpu(a.caustic, scene, alg)
                runs.setdefault((scene, alg), []).append((refs, ours))
    names = [os.path.basename(b) for b in a.smallvcm]
    print("| scene | alg | " + " | ".join(names) + " | caustic | "
          + " | ".join(f"ratio to {n}" for n in names) + " |")
    print("|---" * (3 + 2 * len(names)) + "|")
    for (scene, alg), rs in runs.items():
        med = statistics.median
        refs = [med(r[0][i] for r in rs) for i in range(len(names))]
        ratios = [med(r[1] / r[0][i] for r in rs) for i in range(len(names))]
        ours = med(r[1] for r in rs)
        print(f"| {scene} | {alg} | " + " | ".join(f"{x:.3f}" for x in refs)
              + f" | {ours:.3f} | " + " | ".join(f"{x:.2f}" for x in ratios) + " |")


if __name__ == "__main__":
    main()
