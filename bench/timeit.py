"""Whole-process times of lincal binaries side by side: 11 rounds, the binaries interleaved in
each, LINCAL_CACHE=off; prints each binary's median and minimum.

Usage: python3 bench/timeit.py BIN[,BIN...] ARGS...
e.g.   python3 bench/timeit.py old/lincal,target/release/lincal calibrate SPEC DATA --refine
"""

import os
import statistics
import subprocess
import sys
import time


def main() -> None:
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    bins = sys.argv[1].split(",")
    args = sys.argv[2:]
    env = dict(os.environ, LINCAL_CACHE="off")
    times = {b: [] for b in bins}
    for _ in range(11):
        for b in bins:
            t = time.perf_counter()
            subprocess.run([b, *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           env=env, check=True)
            times[b].append(time.perf_counter() - t)
    for b in bins:
        print(f"{b}: median {statistics.median(times[b]) * 1e3:.1f} ms, "
              f"min {min(times[b]) * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
